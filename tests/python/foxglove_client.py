"""A Foxglove WebSocket client: connects with the protocol's subprotocol,
subscribes to one topic and writes every message it receives.

usage: foxglove_client.py URL TOPIC OUT.jsonl MAX_SECONDS IDLE_SECONDS

Writes one JSON line per message: {"log_time": ns, "msg": <the JSON payload>}.
Stops IDLE_SECONDS after the last message (once one arrived) or after
MAX_SECONDS. Prints one JSON line: the negotiated subprotocol, the server
name, the topics advertised and the number of messages.
"""

import json
import struct
import sys
import time

from websockets.sync.client import connect

SUBPROTOCOL = "foxglove.sdk.v1"


def main():
    url, topic, out, max_s, idle_s = sys.argv[1:6]
    max_s, idle_s = float(max_s), float(idle_s)
    t0 = time.monotonic()
    last = None
    n = 0
    topics = []
    server = None
    sub_id = 1
    with connect(url, subprotocols=[SUBPROTOCOL], open_timeout=10, max_size=None) as ws, open(out, "w") as f:
        if ws.subprotocol != SUBPROTOCOL:
            sys.exit(f"foxglove_client: server chose subprotocol {ws.subprotocol!r}")
        subscribed = False
        while True:
            now = time.monotonic()
            if now - t0 > max_s or (last is not None and now - last > idle_s):
                break
            try:
                m = ws.recv(timeout=0.2)
            except TimeoutError:
                continue
            if isinstance(m, str):
                op = json.loads(m)
                if op.get("op") == "serverInfo":
                    server = op.get("name")
                elif op.get("op") == "advertise":
                    for ch in op["channels"]:
                        topics.append(ch["topic"])
                        if ch["topic"] == topic and not subscribed:
                            ws.send(json.dumps({"op": "subscribe", "subscriptions": [{"id": sub_id, "channelId": ch["id"]}]}))
                            subscribed = True
                            print(f"foxglove_client: subscribed to {topic}", file=sys.stderr, flush=True)
                continue
            opcode = m[0]
            if opcode != 0x01:
                continue
            sid, log_time = struct.unpack_from("<IQ", m, 1)
            if sid != sub_id:
                sys.exit(f"foxglove_client: message for subscription {sid}")
            f.write(json.dumps({"log_time": log_time, "msg": json.loads(m[13:])}) + "\n")
            n += 1
            last = time.monotonic()
    print(json.dumps({"subprotocol": SUBPROTOCOL, "server": server, "topics": sorted(set(topics)), "messages": n}))


if __name__ == "__main__":
    main()
