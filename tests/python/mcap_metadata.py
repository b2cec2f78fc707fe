"""Reads an MCAP file's metadata records and message time span with the
reference reader (PyPI `mcap`).

usage: mcap_metadata.py FILE.mcap

Prints one JSON line: {"metadata": {NAME: {KEY: VALUE}}, "message_start_time":
ns, "message_end_time": ns, "topics": [...]}. Fails with a message naming the
file when it has no summary or two metadata records share a name.
"""

import json
import sys

from mcap.reader import make_reader


def main():
    path = sys.argv[1]
    with open(path, "rb") as f:
        reader = make_reader(f)
        meta = {}
        for m in reader.iter_metadata():
            if m.name in meta:
                sys.exit(f"mcap_metadata: {path}: two metadata records named {m.name!r}")
            meta[m.name] = dict(m.metadata)
        summary = reader.get_summary()
        if summary is None or summary.statistics is None:
            sys.exit(f"mcap_metadata: {path}: no summary statistics")
        st = summary.statistics
        topics = sorted({ch.topic for ch in summary.channels.values()})
    print(json.dumps({
        "metadata": meta,
        "message_start_time": st.message_start_time,
        "message_end_time": st.message_end_time,
        "topics": topics,
    }))


if __name__ == "__main__":
    main()
