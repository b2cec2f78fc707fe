"""A KVH 1750 on a pseudo-terminal, written from the message layout alone
(examples/c/kvh1750.c's comment and the unit's manual), not from the
driver's code: 36-byte big-endian messages with a CRC-32/MPEG-2
(polynomial 0x04C11DB7, initial 0xFFFFFFFF, not reflected, no final XOR)
at the unit's rate, paced on an absolute schedule.

    python3 kvh_feed.py LINK RATE_HZ COUNT EXPECTED_JSON

Creates a pty, links LINK to its terminal, prints "ready", waits for a
line on stdin (the reader has opened it), then writes COUNT message slots: garbage with a
false header before slot 10, slot 50's CRC damaged, slots 100 to 102 not
sent (a gap of three periods), the sequence counter wrapping at 128. Writes
the messages that should arrive (slot, sequence, the float values as the
unit's float32 has them) to EXPECTED_JSON, prints "sent", and closes the terminal at the next line on
stdin (when the test has every message).
"""

import json
import os
import pty
import struct
import sys
import time


def crc32_mpeg2(data: bytes) -> int:
    crc = 0xFFFFFFFF
    for byte in data:
        crc ^= byte << 24
        for _ in range(8):
            crc = ((crc << 1) ^ 0x04C11DB7) if crc & 0x80000000 else crc << 1
            crc &= 0xFFFFFFFF
    return crc


def f32(x: float) -> float:
    return struct.unpack(">f", struct.pack(">f", x))[0]


def main() -> None:
    link, rate, count, expected_path = sys.argv[1], float(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
    master, slave = os.openpty()
    name = os.ttyname(slave)
    if os.path.lexists(link):
        os.unlink(link)
    os.symlink(name, link)
    # Raw terminal: no echo, no line discipline on what is written.
    import tty

    tty.setraw(slave)
    expected = []
    # The test starts the driver on LINK, then says "go" on stdin.
    print("ready", flush=True)
    sys.stdin.readline()
    t0 = time.monotonic() + 0.1
    for slot in range(count):
        seq = slot % 128
        gyro = [1e-5 * (slot % 17) - 3e-5, 2e-6 * slot, -4.5e-5]
        accel = [0.01 * (slot % 5), -0.002, 9.80665 / rate + 1e-4 * (slot % 3)]
        body = struct.pack(">I6fBBh", 0xFE81FF55, *gyro, *accel, 0x77, seq, 31)
        msg = body + struct.pack(">I", crc32_mpeg2(body))
        if 100 <= slot <= 102:
            continue
        out = b""
        if slot == 10:
            out += bytes([0x00, 0x13, 0xFE, 0x81, 0xFF, 0x55]) + bytes(range(7, 19))
        if slot == 50:
            msg = msg[:8] + bytes([msg[8] ^ 0x40]) + msg[9:]
        else:
            expected.append({"slot": slot, "seq": seq, "gyro": [f32(g) for g in gyro], "accel": [f32(a) for a in accel]})
        out += msg
        delay = t0 + slot / rate - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        os.write(master, out)
    with open(expected_path, "w") as f:
        json.dump(expected, f)
    # The test closes the terminal once the driver has published them all.
    print("sent", flush=True)
    sys.stdin.readline()
    os.close(master)
    os.close(slave)
    os.unlink(link)


if __name__ == "__main__":
    main()
