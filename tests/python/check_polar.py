"""Composes the polar frame tree of a polarnav MCAP file with the reference
reader (PyPI `mcap`, `mcap-protobuf-support`) and checks it against the
solutions in the same file.

usage: check_polar.py FILE.mcap

For every `/solution/pose` transform (parent `polar_north` or
`polar_south`, child `body`; one per 50 ms of sensor time): composed with
the `/tf/polar` transform `ecef` -> that frame it gives the ECEF position
(to 1 mm) and attitude (to 1e-6 rad) of the `/solution` message of the
same time (protobuf `polarnav.Solution`); there is one every 50 ms. `/track` has solution
segments in the polar frames whose points lie on the solutions' positions
(each within 1 mm of some `/solution` position mapped into its frame
through `/tf/polar`: every solution, not only the 20 Hz poses, so a track
point between two poses, e.g. after a frame switch restarts the display
schedule, is still found). Prints one JSON line:
counts, the largest position and attitude differences, the frames used.
"""

import json
import math
import sys

from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory


def qmul(a, b):
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    )


def rotate(q, v):
    w, x, y, z = q
    p = qmul(qmul(q, (0.0, v[0], v[1], v[2])), (w, -x, -y, -z))
    return p[1:]


def angle(a, b):
    d = abs(sum(x * y for x, y in zip(a, b)))
    return 2.0 * math.acos(min(1.0, d))


def fail(msg):
    print(msg, file=sys.stderr)
    sys.exit(1)


def main():
    path = sys.argv[1]
    tf = {}
    poses = {}
    solutions = []
    track_points = []
    track_frames = set()
    entities = set()
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _, _, _, m in reader.iter_decoded_messages(topics=["/solution"]):
            solutions.append(
                {"t_ns": m.t_ns, "r_e_m": (m.x_m, m.y_m, m.z_m), "q_b_e": (m.qw, m.qx, m.qy, m.qz)}
            )
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for schema, channel, message, decoded in reader.iter_decoded_messages(
            topics=["/tf/polar", "/solution/pose", "/track"]
        ):
            t = channel.topic
            if t == "/tf/polar":
                if decoded.parent_frame_id != "ecef":
                    fail(f"/tf/polar at {message.log_time}: parent {decoded.parent_frame_id}")
                tf[decoded.child_frame_id] = decoded
            elif t == "/solution/pose":
                if decoded.child_frame_id != "body":
                    fail(f"/solution/pose at {message.log_time}: child {decoded.child_frame_id}")
                if schema.name != "foxglove.FrameTransform":
                    fail(f"/solution/pose schema {schema.name}")
                poses[message.log_time] = decoded
            elif t == "/track":
                if schema.name != "foxglove.SceneUpdate":
                    fail(f"/track schema {schema.name}")
                for e in decoded.entities:
                    entities.add(e.id)
                    if e.id.startswith("solution-"):
                        track_frames.add(e.frame_id)
                        for line in e.lines:
                            for p in line.points:
                                track_points.append((e.frame_id, (p.x, p.y, p.z)))
    if not solutions:
        fail("no /solution messages")
    worst_pos = worst_att = 0.0
    frames = set()
    by_t = {s["t_ns"]: s for s in solutions}
    span_s = (solutions[-1]["t_ns"] - solutions[0]["t_ns"]) * 1e-9
    if not poses or len(poses) < 20 * span_s:
        fail(f"{len(poses)} /solution/pose messages over {span_s} s: fewer than 20 a second")
    for t_ns, pose in sorted(poses.items()):
        s = by_t.get(t_ns)
        if s is None:
            fail(f"/solution/pose at {t_ns}: no /solution at that time")
        parent = pose.parent_frame_id
        frames.add(parent)
        if parent not in tf:
            fail(f"/solution/pose at {s['t_ns']}: no /tf/polar for {parent} before it")
        e = tf[parent]
        q_ep = (e.rotation.w, e.rotation.x, e.rotation.y, e.rotation.z)
        q_pb = (pose.rotation.w, pose.rotation.x, pose.rotation.y, pose.rotation.z)
        tp = (pose.translation.x, pose.translation.y, pose.translation.z)
        r = rotate(q_ep, tp)
        r = (r[0] + e.translation.x, r[1] + e.translation.y, r[2] + e.translation.z)
        worst_pos = max(worst_pos, math.dist(r, s["r_e_m"]))
        worst_att = max(worst_att, angle(qmul(q_ep, q_pb), s["q_b_e"]))
    if worst_pos > 1e-3:
        fail(f"ecef -> polar -> body position differs from the solution by {worst_pos} m")
    if worst_att > 1e-6:
        fail(f"ecef -> polar -> body attitude differs from the solution by {worst_att} rad")
    if not track_points:
        fail("/track has no solution segment")
    # Every track point is a solution's position in the same frame: every
    # /solution position mapped into each track frame (p = R_ep^T (r - t)),
    # hashed by 1 m cell so that each point looks only at its neighbours.
    cells = {}
    for frame in track_frames:
        if frame not in tf:
            fail(f"/track frame {frame} has no /tf/polar transform")
        e = tf[frame]
        q_pe = (e.rotation.w, -e.rotation.x, -e.rotation.y, -e.rotation.z)
        for s in solutions:
            r = s["r_e_m"]
            p = rotate(q_pe, (r[0] - e.translation.x, r[1] - e.translation.y, r[2] - e.translation.z))
            key = (frame, *(math.floor(c) for c in p))
            cells.setdefault(key, []).append(p)
    worst_track = 0.0
    for frame, p in track_points[:: max(1, len(track_points) // 500)]:
        c = [math.floor(x) for x in p]
        near = min(
            (
                math.dist(p, q)
                for dx in (-1, 0, 1)
                for dy in (-1, 0, 1)
                for dz in (-1, 0, 1)
                for q in cells.get((frame, c[0] + dx, c[1] + dy, c[2] + dz), [])
            ),
            default=math.inf,
        )
        worst_track = max(worst_track, near)
    if worst_track > 1e-3:
        fail(f"a /track point lies {worst_track} m from every solution position")
    print(
        json.dumps(
            {
                "solutions": len(solutions),
                "poses_checked": len(poses),
                "worst_position_m": worst_pos,
                "worst_attitude_rad": worst_att,
                "pose_frames": sorted(frames),
                "track_frames": sorted(track_frames),
                "track_points": len(track_points),
                "entities": sorted(x for x in entities if not x.startswith(("solution-", "truth-"))),
                "truth_segments": sum(1 for x in entities if x.startswith("truth-")),
            }
        )
    )


if __name__ == "__main__":
    main()
