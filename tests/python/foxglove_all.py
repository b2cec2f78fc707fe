"""A Foxglove WebSocket client that subscribes to every channel the server
advertises (as it advertises them) and records what arrives.

usage: foxglove_all.py URL MAX_SECONDS IDLE_SECONDS [SUBPROTOCOL ...]

Offers the given subprotocols (default: foxglove.sdk.v1). Stops
IDLE_SECONDS after the last /solution message (once one arrived) or after
MAX_SECONDS. Prints one JSON line:
  {"subprotocol": negotiated, "advertised": [every topic ever advertised],
   "unadvertised": [...], "counts": {topic: messages},
   "log_times": {topic: [first, last]}}
or, when the server refuses the handshake, {"refused": HTTP status, "body": text}.
Writes "foxglove_all: subscribed to TOPIC" to stderr for each subscription.
"""

import json
import struct
import sys
import time

from websockets.exceptions import InvalidStatus
from websockets.sync.client import connect


def main():
    url, max_s, idle_s = sys.argv[1], float(sys.argv[2]), float(sys.argv[3])
    offered = sys.argv[4:] or ["foxglove.sdk.v1"]
    t0 = time.monotonic()
    last_solution = None
    topic_of_sub = {}
    advertised, unadvertised = [], []
    counts, log_times = {}, {}
    next_sub = 1
    try:
        ws = connect(url, subprotocols=offered, open_timeout=10, max_size=None)
    except InvalidStatus as e:
        body = e.response.body.decode("utf-8", "replace") if e.response.body else ""
        print(json.dumps({"refused": e.response.status_code, "body": body}))
        return
    with ws:
        while True:
            now = time.monotonic()
            if now - t0 > max_s or (last_solution is not None and now - last_solution > idle_s):
                break
            try:
                m = ws.recv(timeout=0.2)
            except TimeoutError:
                continue
            if isinstance(m, str):
                op = json.loads(m)
                if op.get("op") == "advertise":
                    subs = []
                    for ch in op["channels"]:
                        advertised.append(ch["topic"])
                        topic_of_sub[next_sub] = ch["topic"]
                        subs.append({"id": next_sub, "channelId": ch["id"]})
                        print(f"foxglove_all: subscribed to {ch['topic']}", file=sys.stderr, flush=True)
                        next_sub += 1
                    if subs:
                        ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))
                elif op.get("op") == "unadvertise":
                    unadvertised.extend(op.get("channelIds", []))
                continue
            if m[0] != 0x01:
                continue
            sid, log_time = struct.unpack_from("<IQ", m, 1)
            topic = topic_of_sub.get(sid)
            if topic is None:
                sys.exit(f"foxglove_all: message for unknown subscription {sid}")
            counts[topic] = counts.get(topic, 0) + 1
            span = log_times.setdefault(topic, [log_time, log_time])
            span[1] = log_time
            if topic == "/solution":
                last_solution = time.monotonic()
        negotiated = ws.subprotocol
    print(json.dumps({
        "subprotocol": negotiated,
        "advertised": sorted(set(advertised)),
        "unadvertised": unadvertised,
        "counts": counts,
        "log_times": log_times,
    }))


if __name__ == "__main__":
    main()
