"""A land cover as CORINE ships it, and the same codes as a plain integer band: OUT/corine.tif
(uint8 with a colour table, codes 1 to 44 in patches, 48 where there is no data, 100 m
cells in LAEA Europe, EPSG:3035) and OUT/codes.tif (the same values, no colour table), with
OUT/demonstrations.parquet (three straight episodes across the raster, no map column, as
pyarrow writes a table). Prints one JSON line per file."""

import json
import os
import sys

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import rasterio
from rasterio.transform import from_origin

out = sys.argv[1]
os.makedirs(out, exist_ok=True)
width, height, cell = 160, 120, 100.0
west, north = 4_300_000.0, 3_300_000.0

# Patches: each cell takes the code of its nearest of 300 seeded centres, every code of
# 1..44 given to some centre, so that all 44 classes are present.
rng = np.random.default_rng(44)
centres = rng.uniform([0, 0], [height, width], size=(300, 2))
codes = np.concatenate([np.arange(1, 45), rng.integers(1, 45, 300 - 44)])
rows, cols = np.mgrid[0:height, 0:width]
nearest = np.argmin(
    (rows[..., None] - centres[:, 0]) ** 2 + (cols[..., None] - centres[:, 1]) ** 2, axis=-1)
land_cover = codes[nearest].astype("uint8")
land_cover[:6, :20] = 48  # CORINE's "no data" code

profile = dict(driver="GTiff", width=width, height=height, count=1, dtype="uint8",
               crs="EPSG:3035", transform=from_origin(west, north, cell, cell), nodata=48,
               compress="lzw")
colours = {i: (int(37 * i) % 256, int(91 * i) % 256, int(53 * i) % 256, 255) for i in range(256)}
for name, palette in [("corine", True), ("codes", False)]:
    path = os.path.join(out, name + ".tif")
    with rasterio.open(path, "w", photometric="palette" if palette else "minisblack",
                       **profile) as dst:
        dst.write(land_cover[None])
        if palette:
            dst.write_colormap(1, colours)
    print(json.dumps({"file": path, "palette": palette}))

# Episodes from the west edge to the east edge along three rows, a pose per cell.
episode, t, x, y = [], [], [], []
for e, row in enumerate([30, 60, 90]):
    for c in range(5, width - 5):
        episode.append(f"drive-{e}")
        t.append(float(c))
        x.append(west + (c + 0.5) * cell)
        y.append(north - (row + 0.5) * cell)
path = os.path.join(out, "demonstrations.parquet")
pq.write_table(pa.table({"episode": episode, "t": t, "x": x, "y": y}), path)
print(json.dumps({"file": path}))
