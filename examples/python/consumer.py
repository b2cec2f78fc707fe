#!/usr/bin/env python3
"""Example consumer of the polarnav daemon over iceoryx2 shared memory.

Subscribes to `<prefix>/solution` and `<prefix>/status` with the `iceoryx2`
package from PyPI (0.10) and the ctypes mirror in polarnav_msgs.py, waking on
the companion event service `<prefix>/solution/event` that the daemon
notifies after every solution.

    pip install iceoryx2==0.10.0
    python3 examples/python/consumer.py [--prefix polarnav] [--csv out.csv]

Like the Rust processes it honours POLARNAV_IOX_PREFIX / POLARNAV_IOX_ROOT
(iceoryx2 file prefix and root directory). One line per status is printed;
`--csv` writes every solution received (shortest round-trip floats).
Sequence-number gaps (samples overwritten because this process fell behind)
are counted, never hidden. Exit status: 0 on success, 1 on a transport error
or timeout, 2 on bad usage.
"""

import argparse
import math
import os
import sys
import time

import iceoryx2 as iox2

from polarnav_msgs import AIDS, FLAG_IMU_LOST, FRAME_GRID, Solution, Status


def node_config():
    cfg = iox2.config.default()
    prefix = os.environ.get("POLARNAV_IOX_PREFIX")
    root = os.environ.get("POLARNAV_IOX_ROOT")
    if prefix:
        cfg.global_cfg.prefix = iox2.FileName.new(prefix)
    if root:
        cfg.global_cfg.root_path = iox2.Path.new(root.rstrip("/") + "/")
    return cfg


def open_until(what, opener, deadline):
    """Opens a service that the daemon creates, retrying until `deadline`."""
    while True:
        try:
            return opener()
        except Exception as e:  # the service does not exist yet
            if time.monotonic() > deadline:
                raise RuntimeError(f"cannot open {what}: {e}") from e
            time.sleep(0.05)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--prefix", default="polarnav")
    ap.add_argument("--csv", help="write every received solution to this file")
    ap.add_argument("--until-imu-accepted", type=int, default=0,
                    help="exit once a status reports this many accepted IMU samples")
    ap.add_argument("--until-seq", type=int, default=0,
                    help="exit once the solution with this sequence number (or a later one) "
                         "is received; the daemon publishes the solution of the last IMU "
                         "sample when the next arrives or when it stops")
    ap.add_argument("--timeout", type=float, default=0.0,
                    help="give up after this many seconds (0: run until interrupted)")
    args = ap.parse_args()

    iox2.set_log_level_from_env_or(iox2.LogLevel.Warn)
    deadline = time.monotonic() + (args.timeout if args.timeout > 0 else 1e12)
    node = (iox2.NodeBuilder.new()
            .config(node_config())
            .signal_handling_mode(iox2.SignalHandlingMode.Disabled)
            .create(iox2.ServiceType.Ipc))

    def service(leaf):
        return iox2.ServiceName.new(f"{args.prefix.rstrip('/')}/{leaf}")

    sol_service = open_until("solution", lambda: node.service_builder(service("solution"))
                             .publish_subscribe(Solution).open(), deadline)
    status_service = open_until("status", lambda: node.service_builder(service("status"))
                                .publish_subscribe(Status).open(), deadline)
    event_service = open_until("solution event", lambda: node.service_builder(
        service("solution/event")).event().open(), deadline)
    sol_sub = sol_service.subscriber_builder().create()
    status_sub = status_service.subscriber_builder().create()
    listener = event_service.listener_builder().create()
    print(f"subscribed to {args.prefix}/solution and {args.prefix}/status", flush=True)

    csv = open(args.csv, "w") if args.csv else None
    if csv:
        csv.write("t_ns,seq,lat_rad,lon_rad,h_m,r_x,r_y,r_z,v_x,v_y,v_z,"
                  "q_w,q_x,q_y,q_z,heading_rad,sigma_e,sigma_n,sigma_u,flags,frame\n")
    received = 0
    gaps = 0
    last_seq = None
    last = None
    try:
        while True:
            if time.monotonic() > deadline:
                print(f"timeout after {args.timeout} s: {received} solutions", file=sys.stderr)
                return 1
            listener.timed_wait(iox2.Duration.from_millis(100))
            while (sample := sol_sub.receive()) is not None:
                s = sample.payload().contents
                if last_seq is not None and s.seq > last_seq + 1:
                    gaps += s.seq - last_seq - 1
                last_seq = s.seq
                received += 1
                last = (s.t_ns, s.lat_rad, s.lon_rad, s.h_m, s.frame)
                if csv:
                    vals = [s.t_ns, s.seq, s.lat_rad, s.lon_rad, s.h_m, *s.r_e_m, *s.v_e_mps,
                            *s.q_b_e, s.heading_rad, *s.sigma_pos_enu_m, s.flags, s.frame]
                    csv.write(",".join(repr(v) for v in vals) + "\n")
                sample.delete()
                if args.until_seq and last_seq >= args.until_seq:
                    print(f"done: {received} solutions received, {gaps} lost to overflow",
                          flush=True)
                    return 0
            while (sample := status_sub.receive()) is not None:
                st = sample.payload().contents
                frame = "grid" if st.frame == FRAME_GRID else "geo"
                pos = (f"lat {math.degrees(last[1]):.6f} lon {math.degrees(last[2]):.6f} "
                       f"h {last[3]:.1f}" if last else "no solution yet")
                aids = "".join(f"{name}={'fresh' if st.aid(name).fresh else 'stale'} "
                               for name in AIDS)
                print(f"status t={st.t_ns * 1e-9:.3f} s frame={frame} {pos} "
                      f"imu={st.imu.accepted}/{st.imu.received} {aids}"
                      f"{'IMU_LOST ' if st.flags & FLAG_IMU_LOST else ''}"
                      f"overruns={st.overruns} solutions={received} gaps={gaps}", flush=True)
                done = args.until_imu_accepted and st.imu.accepted >= args.until_imu_accepted
                sample.delete()
                if done:
                    print(f"done: {received} solutions received, {gaps} lost to overflow",
                          flush=True)
                    return 0
    except KeyboardInterrupt:
        print(f"interrupted: {received} solutions received, {gaps} lost to overflow")
        return 0
    finally:
        if csv:
            csv.close()


if __name__ == "__main__":
    sys.exit(main())
