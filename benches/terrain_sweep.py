#!/usr/bin/env python3
"""Rasters of every kind for `imitate bench terrain`: does each read, learn, or get a
clear refusal?

Real files from rasterstats' source archive (its test data, fetched from PyPI with the
SHA-256 its index lists): `slope.tif`, `slope_nodata.tif` (a slope grid of 78 × 84
cells of 25.5 m in a user-defined Albers cone, float32, with and without voids),
`slope_classes.tif` (its classes), `dataset_mask.tif` (float32 in LZW strips with
GDAL's 1-bit internal mask) and `all_nodata.tif`; and layouts made with rasterio from
the Landsat scene of `benches/terrain_imagery.py`: 13 bands, one row, 9 × 12 cells, a
constant, int8, uint32, negative int32, float64 with -9999 voids, mostly NaN, a 6000²
tiled LZW image, palette classes, twenty classes coded as NLCD's, 44 classes coded as CORINE's, infinities, south-up rows, PixelIsPoint, grey with
alpha, ground control points only, and no georeference at all:

    python3 benches/terrain_imagery.py target/imagery
    python3 benches/terrain_sweep.py target/imagery/landsat8_224078.tif target/sweep
    for f in target/sweep/*.tif; do
      target/release/imitate bench terrain $f --method learch-tree --seed 7 --json
    done

Needs rasterio (`scripts/python-deps.sh` installs it into target/python-deps).
"""

import os
import sys
import tarfile
import tempfile
import warnings

import numpy as np
import rasterio
import rasterio.errors
import wheels
from rasterio.control import GroundControlPoint
from rasterio.crs import CRS
from rasterio.transform import Affine, from_origin

landsat, out = sys.argv[1], sys.argv[2]
os.makedirs(out, exist_ok=True)
warnings.filterwarnings("ignore", category=rasterio.errors.NotGeoreferencedWarning)

with tempfile.TemporaryDirectory() as tmp:
    archive = wheels.download_source("rasterstats", "0.21.0", tmp)
    with tarfile.open(archive) as tar:
        for name in ["slope", "slope_nodata", "slope_classes", "dataset_mask", "all_nodata"]:
            member = tar.extractfile(f"rasterstats-0.21.0/tests/data/{name}.tif")
            path = os.path.join(out, name + ".tif")
            with open(path, "wb") as dst:
                dst.write(member.read())
            print(path)

with rasterio.open(landsat) as src:
    bands = src.read().astype(np.float64)
first = bands[0]


def write(name, values, dtype, transform=from_origin(500000, 7200000, 30, 30),
          crs="EPSG:32621", **creation):
    values = np.asarray(values)
    if values.ndim == 2:
        values = values[None]
    path = os.path.join(out, name + ".tif")
    with rasterio.open(path, "w", driver="GTiff", width=values.shape[2],
                       height=values.shape[1], count=values.shape[0], dtype=dtype,
                       crs=crs, transform=transform, **creation) as dst:
        dst.write(values.astype(dtype))
    print(path)
    return path


rng = np.random.default_rng(1)
thirteen = np.concatenate([bands, 0.8 * bands + 100, 1.1 * bands[::-1],
                           0.5 * bands + rng.normal(0, 50, bands.shape), 0.7 * bands[:1]])
write("thirteen_bands", thirteen[:, :600, :600], "uint16", compress="deflate")
write("one_row", first[:1, :500], "uint16")
write("nine_by_twelve", first[:9, :12], "uint16")
write("constant", np.full((200, 300), 7), "uint8")
write("int8", first[:500, :500] / 100 - 100, "int8")
write("uint32", first[:500, :500] * 1000, "uint32")
write("int32_negative", first[:500, :500] - 20000, "int32")
voids = first[:800, :800] / 10
voids[100:300, 200:500] = -9999
write("float64_voids", voids, "float64", nodata=-9999)
sparse = np.full((500, 500), np.nan)
sparse[200:230, 100:400] = 5.0
write("mostly_nan", sparse, "float32", nodata=np.nan)
write("tiled_6000", np.tile(first[:1000, :1000] / 256, (6, 6)), "uint8", compress="lzw",
      tiled=True)
classes = np.digitize(first[:600, :600], np.quantile(first, [0.2, 0.4, 0.6, 0.8])) * 10 + 10
path = write("palette_classes", classes, "uint8", photometric="palette")
with rasterio.open(path, "r+") as dst:
    dst.write_colormap(1, {10: (0, 100, 0, 255), 20: (255, 255, 0, 255), 30: (0, 0, 255, 255),
                           40: (128, 128, 128, 255), 50: (255, 0, 0, 255)})
# Twenty classes coded as NLCD's land-cover codes (11 water … 95 wetland), quantiles of
# the first band: codes with gaps, more classes than a depth-3 tree has leaves.
nlcd = np.array([11, 12, 21, 22, 23, 24, 31, 41, 42, 43, 51, 52, 71, 72, 73, 74, 81, 82, 90, 95])
write("nlcd_codes", nlcd[np.digitize(first, np.quantile(first, np.linspace(0, 1, 21)[1:-1]))],
      "uint8", compress="deflate")
# A land cover of 44 classes as CORINE ships it (codes 1 to 44, a colour table): k-means
# clusters of the four bands, each cluster a seeded code. The codes are in no order, and
# more than a layer's values are read as classes by (the colour table declares them).
pixels = np.log1p(np.maximum(bands, 0)).reshape(len(bands), -1).T
pixels = (pixels - pixels.mean(0)) / (pixels.std(0) + 1e-9)
centres = pixels[rng.choice(len(pixels), 44, replace=False)]
sample = pixels[rng.choice(len(pixels), 20000, replace=False)]
for _ in range(25):
    nearest = np.argmin(((sample[:, None] - centres[None]) ** 2).sum(-1), axis=1)
    for k in range(44):
        if (nearest == k).any():
            centres[k] = sample[nearest == k].mean(0)
nearest = np.concatenate([np.argmin(((chunk[:, None] - centres[None]) ** 2).sum(-1), axis=1)
                          for chunk in np.array_split(pixels, 64)])
corine = (rng.permutation(44) + 1)[nearest].reshape(first.shape)
path = write("corine_codes", corine, "uint8", compress="lzw", photometric="palette")
with rasterio.open(path, "r+") as dst:
    dst.write_colormap(1, {i: ((37 * i) % 256, (91 * i) % 256, (53 * i) % 256, 255)
                           for i in range(256)})
small = first[:400, :400]
infinite = small.copy()
infinite[50:60, 50:200] = np.inf
infinite[300:310, :] = -np.inf
write("infinities", infinite, "float32")
write("south_up", small[::-1], "float32",
      transform=Affine(30, 0, 500000, 0, 30, 7200000 - 400 * 30))
path = write("pixel_is_point", small, "float32")
with rasterio.open(path, "r+") as dst:
    dst.update_tags(AREA_OR_POINT="Point")
alpha = np.where(np.arange(400)[None, :] < 100, 0, 255).repeat(400, 0)
write("grey_alpha", np.stack([small / 100, alpha]), "uint8", photometric="minisblack",
      alpha="yes")
for name, gcps in [("gcps_only", True), ("no_georeference", False)]:
    path = os.path.join(out, name + ".tif")
    with rasterio.open(path, "w", driver="GTiff", width=400, height=400, count=1,
                       dtype="float32") as dst:
        dst.write(small[None].astype("float32"))
        if gcps:
            dst.gcps = ([GroundControlPoint(0, 0, 500000, 7200000),
                         GroundControlPoint(0, 400, 512000, 7200000),
                         GroundControlPoint(400, 0, 500000, 7188000)], CRS.from_epsg(32621))
    print(path)
