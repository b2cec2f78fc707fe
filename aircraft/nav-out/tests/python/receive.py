"""Independent decoder of the bridges' output for nav-out's tests.

    receive.py mavlink|nmea OUT.jsonl [--serial LINK]

Binds a UDP socket on 127.0.0.1 (any port), prints "PORT <n>" on stdout,
then decodes every datagram with PyPI pymavlink (MAVLink 2, common
dialect, CRC checked with each message's CRC_EXTRA) or pynmeagps
(checksum validated) until standard input closes, writing one JSON line
per decoded message: arrival time ("t", time.time()), datagram number,
message name ("msg") and fields. A last line {"summary": ...} counts datagrams, messages,
and everything that did not decode (bad CRC, bad checksum, stray bytes).

With --serial LINK (nmea only) it reads a pseudo-terminal instead: LINK is
made a symlink to the terminal's slave side, and a line "CYCLE" on
standard input closes that terminal (the device goes away) and, after 1.5 s,
opens a new one behind the same LINK (the device comes back).
"""

import json
import os
import select
import socket
import sys
import time


def plain(v):
    if isinstance(v, float) and v != v:
        return None  # NaN (JSON has none)
    if isinstance(v, (int, float, str)) or v is None:
        return v
    if isinstance(v, (list, tuple)):
        return [plain(x) for x in v]
    if isinstance(v, bytes):
        return v.hex()
    return str(v)


def mavlink_decoder():
    os.environ["MAVLINK20"] = "1"
    from pymavlink.dialects.v20 import common as mav

    m = mav.MAVLink(None)
    m.robust_parsing = True

    def decode(data):
        out, bad = [], 0
        for msg in m.parse_buffer(data) or []:
            t = msg.get_type()
            if t == "BAD_DATA":
                bad += 1
                continue
            d = {k: plain(v) for k, v in msg.to_dict().items() if k != "mavpackettype"}
            d["msg"] = t
            d["sysid"] = msg.get_srcSystem()
            d["compid"] = msg.get_srcComponent()
            d["seq"] = msg.get_seq()
            d["crc"] = msg.get_crc()
            out.append(d)
        # Bytes left in the parser's buffer are a frame that never completed.
        left = len(m.buf) - m.buf_index if hasattr(m, "buf_index") else 0
        return out, bad + (1 if left else 0)

    return decode


def nmea_decoder():
    from pynmeagps import NMEAReader, VALCKSUM

    pending = b""

    def decode(data):
        nonlocal pending
        out, bad = [], 0
        pending += data
        *lines, pending = pending.split(b"\r\n")
        for line in lines:
            if not line:
                continue
            try:
                msg = NMEAReader.parse(line + b"\r\n", validate=VALCKSUM)
            except Exception as e:  # a bad checksum or a malformed sentence
                bad += 1
                sys.stderr.write(f"bad sentence {line!r}: {e}\n")
                continue
            d = {k: plain(v) for k, v in vars(msg).items() if not k.startswith("_")}
            d["msg"] = msg.msgID
            d["talker"] = msg.talker
            d["raw"] = line.decode("ascii")
            out.append(d)
        return out, bad

    return decode


def main():
    kind, out_path = sys.argv[1], sys.argv[2]
    serial_link = sys.argv[4] if len(sys.argv) > 4 and sys.argv[3] == "--serial" else None
    decode = mavlink_decoder() if kind == "mavlink" else nmea_decoder()
    summary = {"datagrams": 0, "messages": 0, "bad": 0, "cycles": 0}
    master = None
    sock = None

    def open_pty():
        nonlocal master
        import pty

        master, slave = pty.openpty()
        name = os.ttyname(slave)
        os.close(slave)  # the bridge opens it; the master side keeps it alive
        tmp = serial_link + ".tmp"
        if os.path.lexists(tmp):
            os.remove(tmp)
        os.symlink(name, tmp)
        os.replace(tmp, serial_link)

    if serial_link:
        open_pty()
        print("PORT 0", flush=True)
    else:
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 22)
        sock.bind(("127.0.0.1", 0))
        print(f"PORT {sock.getsockname()[1]}", flush=True)
    reopen_at = None
    with open(out_path, "w") as out:
        stdin_open = True
        while stdin_open:
            if reopen_at is not None and time.time() >= reopen_at:
                open_pty()
                reopen_at = None
            fds = [sys.stdin]
            if sock is not None:
                fds.append(sock)
            if master is not None:
                fds.append(master)
            ready, _, _ = select.select(fds, [], [], 0.05)
            for r in ready:
                if r is sys.stdin:
                    line = sys.stdin.readline()
                    if not line:
                        stdin_open = False
                    elif line.strip() == "CYCLE" and master is not None:
                        os.close(master)
                        master = None
                        os.remove(serial_link)
                        summary["cycles"] += 1
                        reopen_at = time.time() + 1.5
                    continue
                if r is sock:
                    data, _ = sock.recvfrom(65536)
                else:
                    try:
                        data = os.read(master, 65536)
                    except OSError:
                        continue
                t = time.time()
                summary["datagrams"] += 1
                msgs, bad = decode(data)
                summary["bad"] += bad
                for d in msgs:
                    d["t"] = t
                    d["datagram"] = summary["datagrams"]
                    summary["messages"] += 1
                    out.write(json.dumps(d) + "\n")
        out.write(json.dumps({"summary": summary}) + "\n")


if __name__ == "__main__":
    main()
