#!/usr/bin/env python3
"""The fixes a real receiver's log holds, read by PyPI pyubx2 (independent
of the driver's decoder and framer), for the gnss-ubx log tests.

    ubx_log_fixes.py LOG.ubx EXPECTED.json

pyubx2 reads the whole log (UBX, NMEA and RTCM interleaved on one port);
each NAV-PVT becomes the GnssFix the driver must publish for it, through
the driver's documented time rule (`ubx_feed.TimeRule`), with `seq`
counting the published fixes from 0. Writes {"nav_pvt": N, "fixes": [...]}.
"""

import json
import sys

from pyubx2 import UBX_PROTOCOL, NMEA_PROTOCOL, RTCM3_PROTOCOL, UBXReader

from ubx_feed import TimeRule, expected_fix


def main():
    log, out = sys.argv[1], sys.argv[2]
    rule = TimeRule()
    fixes = []
    nav_pvt = 0
    with open(log, "rb") as f:
        reader = UBXReader(
            f,
            protfilter=UBX_PROTOCOL | NMEA_PROTOCOL | RTCM3_PROTOCOL,
            quitonerror=0,
        )
        for _raw, m in reader:
            if m is None or getattr(m, "identity", None) != "NAV-PVT":
                continue
            nav_pvt += 1
            t = rule.t_ns(m)
            if t is not None:
                fixes.append(expected_fix(m, t, len(fixes)))
    with open(out, "w") as f:
        json.dump({"nav_pvt": nav_pvt, "fixes": fixes}, f)


if __name__ == "__main__":
    main()
