"""Reads a polarnav MCAP file with the reference reader (PyPI `mcap`) and
checks it against the solution CSV of the same run.

usage: check_mcap.py FILE.mcap [SOLUTION.csv] [--require TOPIC ...]

Checks, failing with a message that names the topic, message or row:
- every channel has a schema with data; `/solution/fix` and `/truth/fix`
  (when present) are `foxglove.LocationFix` in protobuf and decode;
- every message's log time is its own `t_ns` (JSON channels);
- with a CSV: one `/solution` message per CSV row, in order, and every CSV
  column equal (bit for bit) to the value computed from the message as
  the CSV writer computes it.
Prints one JSON line with the per-topic counts.
"""

import csv
import json
import math
import sys

from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory

RAD = 180.0 / math.pi


def csv_values(m):
    """The CSV row's values from a solution message, as the writer forms them."""
    flags = m["flags"]
    bit = lambda b: float((flags >> b) & 1)
    v = {
        "t_s": m["t_ns"] * 1e-9,
        "frame": "gG"[m["frame"]] if m["frame"] in (0, 1) else "?",
        "lat_deg": m["lat_rad"] * RAD,
        "lon_deg": m["lon_rad"] * RAD,
        "h_m": m["h_m"],
        "heading_deg": m["heading_rad"] * RAD,
        "pitch_deg": m["pitch_rad"] * RAD,
        "roll_deg": m["roll_rad"] * RAD,
        "grid_heading_deg": m["grid_heading_rad"] * RAD,
        "flags": float(flags),
        "switch_count": float(m["switch_count"]),
        "reset_count": float(m["reset_count"]),
    }
    for i, k in enumerate(["x_m", "y_m", "z_m"]):
        v[k] = m["r_e_m"][i]
    for i, k in enumerate(["vx_mps", "vy_mps", "vz_mps"]):
        v[k] = m["v_e_mps"][i]
    for i, k in enumerate(["ve_mps", "vn_mps", "vu_mps"]):
        v[k] = m["v_enu_mps"][i]
    for i, k in enumerate(["qw", "qx", "qy", "qz"]):
        v[k] = m["q_b_e"][i]
    for i, k in enumerate(["sig_e_m", "sig_n_m", "sig_u_m"]):
        v[k] = m["sigma_pos_enu_m"][i]
    for i, k in enumerate(["sig_vnav_x_mps", "sig_vnav_y_mps", "sig_vnav_z_mps"]):
        v[k] = m["sigma_vel_mps"][i]
    for i, k in enumerate(["sig_att_x_deg", "sig_att_y_deg", "sig_att_z_deg"]):
        v[k] = m["sigma_att_rad"][i] * RAD
    for i, k in enumerate(["bg_x_rps", "bg_y_rps", "bg_z_rps"]):
        v[k] = m["gyro_bias_rps"][i]
    for i, k in enumerate(["ba_x_mps2", "ba_y_mps2", "ba_z_mps2"]):
        v[k] = m["accel_bias_mps2"][i]
    for i, k in enumerate(["sig_bg_x_rps", "sig_bg_y_rps", "sig_bg_z_rps"]):
        v[k] = m["sigma_gyro_bias_rps"][i]
    for i, k in enumerate(["sig_ba_x_mps2", "sig_ba_y_mps2", "sig_ba_z_mps2"]):
        v[k] = m["sigma_accel_bias_mps2"][i]
    return v, bit


def fail(msg):
    print(f"check_mcap: {msg}", file=sys.stderr)
    sys.exit(1)


def main():
    args = sys.argv[1:]
    required = []
    if "--require" in args:
        i = args.index("--require")
        required = args[i + 1 :]
        args = args[:i]
    path = args[0]
    csv_path = args[1] if len(args) > 1 else None
    counts = {}
    with open(path, "rb") as f:
        reader = make_reader(f)
        protobuf = DecoderFactory()
        decoders = {}
        summary = reader.get_summary()
        if summary is None:
            fail(f"{path}: no summary section")
        for cid, ch in summary.channels.items():
            sc = summary.schemas.get(ch.schema_id)
            if sc is None or not sc.data:
                fail(f"{path}: channel {ch.topic} has no schema")
            if ch.topic.endswith("/fix") and (sc.name, sc.encoding) != ("foxglove.LocationFix", "protobuf"):
                fail(f"{path}: {ch.topic} is {sc.name} ({sc.encoding}), not foxglove.LocationFix")
        topics = {ch.topic for ch in summary.channels.values()}
        for t in required:
            if t not in topics:
                fail(f"{path}: no channel {t} (channels: {sorted(topics)})")
        rows = None
        if csv_path:
            with open(csv_path, newline="") as c:
                rows = csv.DictReader(c)
                rows = list(rows)
        k = 0
        fixes = 0
        for schema, channel, message in reader.iter_messages(log_time_order=False):
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
            if channel.message_encoding == "json":
                m = json.loads(message.data)
                if "t_ns" in m and m["t_ns"] != message.log_time:
                    fail(f"{path}: {channel.topic} message {counts[channel.topic]}: log time {message.log_time} != t_ns {m['t_ns']}")
                if channel.topic == "/solution" and rows is not None:
                    if k >= len(rows):
                        fail(f"{path}: more /solution messages than the {len(rows)} CSV rows")
                    want, bit = csv_values(m)
                    row = rows[k]
                    for col, text in row.items():
                        if col in want:
                            got = want[col]
                            if isinstance(got, str):
                                ok = got == text
                            else:
                                ok = float(text) == got or (math.isnan(got) and math.isnan(float(text)))
                            if not ok:
                                fail(f"{path}: /solution message {k + 1} ({m['t_ns']} ns), CSV row {k + 2} column {col}: {text} != {got!r}")
                    k += 1
            elif channel.topic.endswith("/fix"):
                if channel.id not in decoders:
                    decoders[channel.id] = protobuf.decoder_for(channel.message_encoding, schema)
                decoded = decoders[channel.id](message.data)
                if not (-90.0 <= decoded.latitude <= 90.0) or len(decoded.position_covariance) != 9:
                    fail(f"{path}: {channel.topic}: bad LocationFix {decoded}")
                fixes += 1
        if rows is not None and k != len(rows):
            fail(f"{path}: {k} /solution messages for {len(rows)} CSV rows")
    print(json.dumps({"counts": counts, "solutions_checked": k, "fixes_decoded": fixes}))


if __name__ == "__main__":
    main()
