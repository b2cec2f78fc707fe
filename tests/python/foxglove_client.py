"""A Foxglove WebSocket client: connects with the protocol's subprotocol,
subscribes to one topic (or to every channel, as the server advertises it)
and records what arrives.

usage: foxglove_client.py URL TOPIC OUT.jsonl MAX_SECONDS IDLE_SECONDS [SUBPROTOCOL ...]

TOPIC `*` subscribes to every advertised channel and writes no messages;
otherwise every message of TOPIC goes to OUT.jsonl, one JSON line each:
{"log_time": ns, "data": <the payload in hex>, "schema": <its schema
name>}, after checking that it decodes with the channel's advertised
protobuf schema (mcap-protobuf-support's decoder). Offers the given subprotocols
(default foxglove.sdk.v1). Stops IDLE_SECONDS after the last message of
TOPIC (of /solution for `*`), once one arrived, or after MAX_SECONDS.
Prints one JSON line: the negotiated subprotocol, the server name, the
topics ever advertised and those unadvertised (channel ids), the number of
messages of TOPIC, and per topic the message count and [first, last] log
time; or, when the server refuses the handshake, {"refused": HTTP status,
"body": text}. Writes "foxglove_client: subscribed to T" to stderr for each
subscription.
"""

import base64
import json
import struct
import sys
import time

from mcap.records import Schema
from mcap_protobuf.decoder import DecoderFactory

from websockets.exceptions import InvalidStatus
from websockets.sync.client import connect

SUBPROTOCOL = "foxglove.sdk.v1"


def main():
    url, topic, out, max_s, idle_s = sys.argv[1:6]
    offered = sys.argv[6:] or [SUBPROTOCOL]
    max_s, idle_s = float(max_s), float(idle_s)
    every = topic == "*"
    idle_topic = "/solution" if every else topic
    t0 = time.monotonic()
    last = None
    server = None
    topics, unadvertised = [], []
    topic_of_sub = {}
    channel_of_sub = {}
    decoders = {}
    counts, log_times = {}, {}
    try:
        ws = connect(url, subprotocols=offered, open_timeout=10, max_size=None)
    except InvalidStatus as e:
        body = e.response.body.decode("utf-8", "replace") if e.response.body else ""
        print(json.dumps({"refused": e.response.status_code, "body": body}))
        return
    with ws, open(out, "w") as f:
        if ws.subprotocol not in offered:
            sys.exit(f"foxglove_client: server chose subprotocol {ws.subprotocol!r}")
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
                    subs = []
                    for ch in op["channels"]:
                        topics.append(ch["topic"])
                        if (every or ch["topic"] == topic) and ch["topic"] not in topic_of_sub.values():
                            sid = len(topic_of_sub) + 1
                            topic_of_sub[sid] = ch["topic"]
                            channel_of_sub[sid] = ch
                            subs.append({"id": sid, "channelId": ch["id"]})
                            print(f"foxglove_client: subscribed to {ch['topic']}", file=sys.stderr, flush=True)
                    if subs:
                        ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))
                elif op.get("op") == "unadvertise":
                    unadvertised.extend(op.get("channelIds", []))
                continue
            if m[0] != 0x01:
                continue
            sid, log_time = struct.unpack_from("<IQ", m, 1)
            got = topic_of_sub.get(sid)
            if got is None:
                sys.exit(f"foxglove_client: message for subscription {sid}")
            counts[got] = counts.get(got, 0) + 1
            log_times.setdefault(got, [log_time, log_time])[1] = log_time
            if not every:
                ch = channel_of_sub[sid]
                if ch.get("encoding") != "protobuf" or ch.get("schemaEncoding") != "protobuf":
                    sys.exit(f"foxglove_client: {got} is {ch.get('encoding')!r}, not protobuf")
                if sid not in decoders:
                    schema = Schema(id=sid, name=ch["schemaName"], encoding="protobuf",
                                    data=base64.b64decode(ch["schema"]))
                    decoders[sid] = DecoderFactory().decoder_for("protobuf", schema)
                payload = bytes(m[13:])
                decoders[sid](payload)
                f.write(json.dumps({"log_time": log_time, "data": payload.hex(), "schema": ch["schemaName"]}) + "\n")
            if got == idle_topic:
                last = time.monotonic()
        negotiated = ws.subprotocol
    print(json.dumps({
        "subprotocol": negotiated,
        "server": server,
        "topics": sorted(set(topics)),
        "unadvertised": unadvertised,
        "messages": counts.get(topic, 0),
        "counts": counts,
        "log_times": log_times,
    }))


if __name__ == "__main__":
    main()
