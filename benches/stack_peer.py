"""`ingest --stack` against GDAL's warp (rasterio's `reproject`), in one run.

    stack_peer.py IMITATE WORKDIR [--size N]

Writes a DEM of N x N cells of 3 m in UTM 33N (EPSG:32633), a 3-band uint8 image of 1 m
cells over the same ground (3N x 3N), and the same image warped to EPSG:4326 (about
1 m), all tiled Deflate as GDAL users write them. Then times, best of three wall times:

- imitate: `ingest --stack site=dem.tif,IMAGE --demonstrations ...`, a whole process:
  reading both rasters, laying the image on the DEM's grid, writing the dataset;
- GDAL: reading the image and `reproject(..., Resampling.average)` of its bands onto
  the DEM's grid, in process (rasterio, GDAL_NUM_THREADS=ALL_CPUS), no writing.

Prints one JSON line per image with both times and their ratio.
"""

import json
import os
import subprocess
import sys
import time

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import rasterio
from rasterio.transform import from_origin
from rasterio.warp import Resampling, calculate_default_transform, reproject

imitate, work = sys.argv[1], sys.argv[2]
size = int(sys.argv[sys.argv.index("--size") + 1]) if "--size" in sys.argv else 2000
os.makedirs(work, exist_ok=True)
WEST, NORTH = 500_000.0, 5_000_000.0
PROFILE = dict(driver="GTiff", tiled=True, blockxsize=256, blockysize=256, compress="deflate")


def write(path, crs, transform, data, **extra):
    with rasterio.open(path, "w", width=data.shape[2], height=data.shape[1],
                       count=data.shape[0], dtype=data.dtype, crs=crs, transform=transform,
                       **PROFILE, **extra) as dst:
        dst.write(data)


rng = np.random.default_rng(7)
dem = os.path.join(work, "dem.tif")
if not os.path.exists(dem):
    rows, cols = np.mgrid[0:size, 0:size]
    heights = 1000 + 50 * np.sin(rows / 97.0) * np.cos(cols / 131.0) + rng.normal(0, 1, (size, size))
    write(dem, "EPSG:32633", from_origin(WEST, NORTH, 3.0, 3.0), heights[None].astype("float32"))
image = os.path.join(work, "image.tif")
if not os.path.exists(image):
    n = 3 * size
    bands = rng.integers(0, 255, (3, n, n), dtype="uint8")
    write(image, "EPSG:32633", from_origin(WEST, NORTH, 1.0, 1.0), bands, photometric="rgb")
degrees = os.path.join(work, "image_degrees.tif")
if not os.path.exists(degrees):
    with rasterio.open(image) as src:
        transform, width, height = calculate_default_transform(
            src.crs, "EPSG:4326", src.width, src.height, *src.bounds)
        out = np.zeros((3, height, width), dtype="uint8")
        for b in range(3):
            reproject(rasterio.band(src, b + 1), out[b], dst_transform=transform,
                      dst_crs="EPSG:4326", resampling=Resampling.nearest)
    write(degrees, "EPSG:4326", transform, out, photometric="rgb")

walks = os.path.join(work, "walks.parquet")
pq.write_table(pa.table({
    "episode": ["a", "a"], "map": ["site", "site"], "t": [0.0, 1.0],
    "x": [WEST + 10.0, WEST + 3.0 * size - 10.0], "y": [NORTH - 10.0, NORTH - 3.0 * size + 10.0],
}), walks)


def best(run):
    times = []
    for _ in range(3):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return min(times)


with rasterio.open(dem) as d:
    dst_crs, dst_transform, shape = d.crs, d.transform, d.shape

for name, path in [("image in the DEM's CRS", image), ("image in degrees", degrees)]:
    out = os.path.join(work, "ds")

    def run_imitate():
        subprocess.run([imitate, "ingest", "--stack", f"site={dem},{path}",
                        "--demonstrations", walks, "--out", out],
                       check=True, capture_output=True)

    def run_gdal():
        with rasterio.Env(GDAL_NUM_THREADS="ALL_CPUS"):
            with rasterio.open(path) as src:
                data = src.read()
                for b in range(src.count):
                    target = np.full(shape, np.nan, dtype="float32")
                    reproject(data[b], target, src_transform=src.transform, src_crs=src.crs,
                              dst_transform=dst_transform, dst_crs=dst_crs,
                              dst_nodata=np.nan, resampling=Resampling.average,
                              num_threads=os.cpu_count())

    ours, theirs = best(run_imitate), best(run_gdal)
    print(json.dumps({"image": name, "dem_cells": size * size, "imitate_s": round(ours, 2),
                      "gdal_s": round(theirs, 2), "imitate_over_gdal": round(ours / theirs, 2)}))
