"""Reads a polarnav MCAP file with the reference reader (PyPI `mcap` with
`mcap-protobuf-support`) and checks it against the solution CSV of the same
run.

usage: check_mcap.py FILE.mcap [SOLUTION.csv] [--require TOPIC ...]

Checks, failing with a message that names the topic, message or row:
- every channel is protobuf with a protobuf schema, and every message of
  every channel decodes with it; `/solution/fix` and `/truth/fix` (when
  present) are `foxglove.LocationFix`;
- every message that has a `t_ns` field is logged at that time;
- every `--require`d topic has a channel that carries messages;
- with a CSV: one `/solution` message per CSV row, in order, and every CSV
  column equal (bit for bit) to the message's field of the same name
  (`t_s` from `t_ns`, `frame` as the letter; the velocity columns under
  their names with or without `_mps`, as CSVs of the last version wrote
  them).
Prints one JSON line with the per-topic counts.
"""

import csv
import json
import math
import sys

from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory

# CSV columns of the previous version, read under the field they became.
OLD_NAMES = {
    "vx": "vx_mps",
    "vy": "vy_mps",
    "vz": "vz_mps",
    "ve": "ve_mps",
    "vn": "vn_mps",
    "vu": "vu_mps",
}


def fail(msg):
    print(f"check_mcap: {msg}", file=sys.stderr)
    sys.exit(1)


def field(m, col):
    """The value of CSV column `col` from a decoded /solution message, as
    the CSV writer forms it; None if the message has no such field."""
    if col == "t_s":
        return m.t_ns * 1e-9
    if col == "frame":
        return "gG"[m.frame] if m.frame in (0, 1) else "?"
    name = OLD_NAMES.get(col, col)
    if not hasattr(m, name) or name in ("t_ns",):
        return None
    v = getattr(m, name)
    return float(v)


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
            if ch.message_encoding != "protobuf" or sc.encoding != "protobuf":
                fail(f"{path}: channel {ch.topic} is {ch.message_encoding} with a {sc.encoding} schema, not protobuf")
            if ch.topic.endswith("/fix") and sc.name != "foxglove.LocationFix":
                fail(f"{path}: {ch.topic} is {sc.name}, not foxglove.LocationFix")
        topics = {ch.topic for ch in summary.channels.values()}
        for t in required:
            if t not in topics:
                fail(f"{path}: no channel {t} (channels: {sorted(topics)})")
        per_channel = summary.statistics.channel_message_counts if summary.statistics else {}
        by_topic = {}
        for cid, ch in summary.channels.items():
            by_topic[ch.topic] = by_topic.get(ch.topic, 0) + per_channel.get(cid, 0)
        for t in required:
            if by_topic.get(t, 0) == 0:
                fail(f"{path}: channel {t} carries no message")
        rows = None
        if csv_path:
            with open(csv_path, newline="", encoding="utf-8-sig") as c:
                rows = list(csv.DictReader(c))
        k = 0
        fixes = 0
        inits = []
        compared = set()
        for schema, channel, message in reader.iter_messages(log_time_order=False):
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
            if channel.id not in decoders:
                decoders[channel.id] = protobuf.decoder_for(channel.message_encoding, schema)
            try:
                m = decoders[channel.id](message.data)
            except Exception as e:  # noqa: BLE001 - any decode failure is the finding
                fail(f"{path}: {channel.topic} message {counts[channel.topic]} does not decode as {schema.name}: {e}")
            if hasattr(m, "t_ns") and m.t_ns != message.log_time:
                fail(f"{path}: {channel.topic} message {counts[channel.topic]}: log time {message.log_time} != t_ns {m.t_ns}")
            if channel.topic == "/solution" and rows is not None:
                if k >= len(rows):
                    fail(f"{path}: more /solution messages than the {len(rows)} CSV rows")
                row = rows[k]
                for col, text in row.items():
                    got = field(m, col)
                    if got is None:
                        continue
                    if isinstance(got, str):
                        ok = got == text
                    else:
                        want = float(text)
                        ok = want == got or (math.isnan(got) and math.isnan(want))
                    if not ok:
                        fail(f"{path}: /solution message {k + 1} ({m.t_ns} ns), CSV row {k + 2} column {col}: {text} != {got!r}")
                    compared.add(col)
                k += 1
            elif channel.topic == "/init":
                inits.append({"t_ns": m.t_ns, "method": m.method, "heading_aid": m.heading_aid,
                              "method_name": m.method_name})
            elif channel.topic.endswith("/fix"):
                if not (-90.0 <= m.latitude <= 90.0) or len(m.position_covariance) != 9:
                    fail(f"{path}: {channel.topic}: bad LocationFix {m}")
                fixes += 1
        if rows is not None:
            if k != len(rows):
                fail(f"{path}: {k} /solution messages for {len(rows)} CSV rows")
            missing = [c for c in (rows[0].keys() if rows else []) if c not in compared]
            if missing:
                fail(f"{path}: CSV columns without a /solution field of the same name: {missing}")
    print(json.dumps({"counts": counts, "solutions_checked": k, "fixes_decoded": fixes, "inits": inits}))


if __name__ == "__main__":
    main()
