"""Reads a merged campaign metrics table (`DIR/merged/metrics.parquet`,
written by `sensor-replay campaign merge`) with pandas and pyarrow, and with
polars when it is installed, and checks it against the expectations that
`sensor_replay::campaign::merge::parquet_expectations` gives for its rows.

usage: check_campaign_parquet.py METRICS.parquet EXPECTATIONS

EXPECTATIONS is the JSON itself (starting with `{`) or a file holding it:
    {"rows": N, "columns": [{"name": "index", "type": "uint64",
      "nullable": false, "nulls": 0}, ...]}
with the columns in the table's order; `type` is the Arrow type's name as
pyarrow prints it (uint64, uint32, double, bool, string).

Checks, with each reader: the row count, the column names in order, each
column's type (pyarrow: the Arrow type and the field's nullability; pandas:
the dtype it maps the Arrow type to; polars: its dtype) and null count, and
that `index` rises strictly (rows sorted by run). Prints one JSON line:
rows, the readers used and their versions. Exits 1 with the first mismatch
on stderr.
"""

import json
import sys

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

try:
    import polars as pl
except ImportError:  # polars is optional
    pl = None


def fail(msg):
    print(f"check_campaign_parquet: {msg}", file=sys.stderr)
    sys.exit(1)


def expect(cond, msg):
    if not cond:
        fail(msg)


# The Arrow type of each kind, and what pandas (default, NumPy-backed) and
# polars make of it. pandas turns an integer column with nulls into
# float64 (NaN for null) and a bool column with nulls into object.
ARROW = {
    "uint64": pa.uint64(),
    "uint32": pa.uint32(),
    "double": pa.float64(),
    "bool": pa.bool_(),
    "string": pa.string(),
}


def pandas_ok(kind, nulls, dtype):
    if kind in ("uint64", "uint32"):
        return str(dtype) == (kind if nulls == 0 else "float64")
    if kind == "double":
        return str(dtype) == "float64"
    if kind == "bool":
        return str(dtype) == ("bool" if nulls == 0 else "object")
    # pandas 3 reads strings as its `str` dtype, older pandas as object.
    return pd.api.types.is_string_dtype(dtype) or str(dtype) == "object"


def polars_dtype(kind):
    return {
        "uint64": pl.UInt64,
        "uint32": pl.UInt32,
        "double": pl.Float64,
        "bool": pl.Boolean,
        "string": pl.String,
    }[kind]


def main():
    if len(sys.argv) != 3:
        fail("usage: check_campaign_parquet.py METRICS.parquet EXPECTATIONS")
    path, spec = sys.argv[1], sys.argv[2]
    if spec.lstrip().startswith("{"):
        want = json.loads(spec)
    else:
        with open(spec, encoding="utf-8") as f:
            want = json.load(f)
    rows = want["rows"]
    cols = want["columns"]
    names = [c["name"] for c in cols]

    # pyarrow: the schema as written.
    table = pq.read_table(path)
    expect(table.num_rows == rows, f"pyarrow: {table.num_rows} rows, expected {rows}")
    expect(table.schema.names == names, f"pyarrow: columns {table.schema.names}, expected {names}")
    for c in cols:
        field = table.schema.field(c["name"])
        expect(
            field.type == ARROW[c["type"]],
            f"pyarrow: {c['name']} is {field.type}, expected {c['type']}",
        )
        expect(
            field.nullable == c["nullable"],
            f"pyarrow: {c['name']} nullable {field.nullable}, expected {c['nullable']}",
        )
        got = table.column(c["name"]).null_count
        expect(got == c["nulls"], f"pyarrow: {c['name']} has {got} nulls, expected {c['nulls']}")
    index = table.column("index").to_pylist()
    expect(
        all(a < b for a, b in zip(index, index[1:])),
        "pyarrow: index does not rise strictly",
    )

    # pandas, as a user reads it (NumPy-backed dtypes).
    df = pd.read_parquet(path)
    expect(len(df) == rows, f"pandas: {len(df)} rows, expected {rows}")
    expect(list(df.columns) == names, f"pandas: columns {list(df.columns)}")
    for c in cols:
        dtype = df[c["name"]].dtype
        expect(
            pandas_ok(c["type"], c["nulls"], dtype),
            f"pandas: {c['name']} ({c['type']}, {c['nulls']} nulls) read as {dtype}",
        )
        got = int(df[c["name"]].isna().sum())
        expect(got == c["nulls"], f"pandas: {c['name']} has {got} missing, expected {c['nulls']}")

    readers = {"pyarrow": pa.__version__, "pandas": pd.__version__}
    if pl is not None:
        pf = pl.read_parquet(path)
        expect(pf.height == rows, f"polars: {pf.height} rows, expected {rows}")
        expect(pf.columns == names, f"polars: columns {pf.columns}")
        for c in cols:
            s = pf.get_column(c["name"])
            expect(
                s.dtype == polars_dtype(c["type"]),
                f"polars: {c['name']} is {s.dtype}, expected {c['type']}",
            )
            expect(
                s.null_count() == c["nulls"],
                f"polars: {c['name']} has {s.null_count()} nulls, expected {c['nulls']}",
            )
        readers["polars"] = pl.__version__
    else:
        readers["polars"] = None

    print(json.dumps({"rows": rows, "columns": len(cols), "readers": readers}))


if __name__ == "__main__":
    main()
