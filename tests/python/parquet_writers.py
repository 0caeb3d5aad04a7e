"""Writes one demonstrations table and one map table the way users' tools write them:
pyarrow with every codec, pandas' to_parquet, polars' write_parquet (zstd, its default)
and its other codecs, and the demonstrations as pandas' and polars' CSV. Prints one JSON line per file: {"file", "writer", "table"}.

usage: parquet_writers.py DEMONSTRATIONS.parquet MAP.parquet OUT_DIR
"""

import json
import sys
from pathlib import Path

import pandas as pd
import polars as pl
import pyarrow.parquet as pq

demonstrations, map_table, out = Path(sys.argv[1]), Path(sys.argv[2]), Path(sys.argv[3])
out.mkdir(parents=True, exist_ok=True)


def emit(path, writer, table):
    print(json.dumps({"file": str(path), "writer": writer, "table": table}))


demos = pq.read_table(demonstrations)
# The user's own table: no imitate metadata, only the columns.
plain = demos.replace_schema_metadata(None)
for codec in ["none", "snappy", "gzip", "brotli", "lz4", "zstd"]:
    path = out / f"demos-pyarrow-{codec}.parquet"
    pq.write_table(plain, path, compression=codec)
    emit(path, f"pyarrow {codec}", "demonstrations")

frame = plain.to_pandas()
path = out / "demos-pandas.parquet"
frame.to_parquet(path)
emit(path, "pandas (default)", "demonstrations")
path = out / "demos-pandas-index.parquet"
frame.set_index("episode").to_parquet(path)
emit(path, "pandas (index)", "demonstrations")

polars_frame = pl.from_arrow(plain)
path = out / "demos-polars.parquet"
polars_frame.write_parquet(path)
emit(path, "polars (default: zstd)", "demonstrations")
for codec in ["lz4", "gzip", "brotli", "snappy", "uncompressed"]:
    path = out / f"demos-polars-{codec}.parquet"
    polars_frame.write_parquet(path, compression=codec)
    emit(path, f"polars {codec}", "demonstrations")

# The same table as CSV, as pandas and polars write it (floats in their shortest
# round-trip form): read to the same dataset.
path = out / "demos-pandas.csv"
frame.to_csv(path, index=False)
emit(path, "pandas to_csv", "demonstrations")
path = out / "demos-polars.csv"
polars_frame.write_csv(path)
emit(path, "polars write_csv", "demonstrations")

# A map/1 table keeps its metadata (the georeference); only the codec changes.
grid = pq.read_table(map_table)
# arrow-rs keeps imitate's keys in the file's key-value metadata, which read_table does
# not carry into the schema: carry them over as a user re-encoding the file would.
kept = {k: v for k, v in pq.ParquetFile(map_table).metadata.metadata.items() if k != b"ARROW:schema"}
grid = grid.replace_schema_metadata(kept)
for codec in ["zstd", "gzip", "lz4", "brotli"]:
    path = out / f"map-{codec}.parquet"
    pq.write_table(grid, path, compression=codec)
    emit(path, f"pyarrow {codec}", "map")
