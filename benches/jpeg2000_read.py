"""Reading a Sentinel-2-sized JPEG 2000 band: imitate (rust-j2k) beside GDAL's
JP2OpenJPEG (rasterio, OpenJPEG on every core), in one run.

Writes a 10980 x 10980 uint16 band as Sentinel-2's L1C/L2A files are laid out (UTM,
10 m, lossless 5/3, 1024-cell tiles, 6 resolutions, RPCL), and its GeoTIFF twin (LZW).
Times `imitate plan` on each (it reads the raster as costs and plans two cells apart:
the read is the time) and rasterio's read of the JPEG 2000 band; prints one JSON line.

    PYTHONPATH=target/python-deps python3 benches/jpeg2000_read.py target/release/imitate WORKDIR
"""

import json
import os
import subprocess
import sys
import time

import numpy as np
import rasterio
from rasterio.transform import from_origin

imitate, work = sys.argv[1], sys.argv[2]
os.makedirs(work, exist_ok=True)
n = 10980
rng = np.random.default_rng(0)
coarse = rng.normal(size=(n // 20 + 1, n // 20 + 1)).cumsum(0).cumsum(1)
field = np.kron(coarse, np.ones((20, 20)))[:n, :n]
field = (field - field.min()) / (field.max() - field.min())
band = (field * 8000 + 500 + rng.normal(scale=30, size=(n, n))).astype("uint16")
profile = dict(width=n, height=n, count=1, dtype="uint16", crs="EPSG:32632",
               transform=from_origin(399960, 5100000, 10, 10))
jp2 = os.path.join(work, "T32TLR_B04.jp2")
tif = os.path.join(work, "T32TLR_B04.tif")
with rasterio.open(jp2, "w", driver="JP2OpenJPEG", QUALITY=100, REVERSIBLE="YES",
                   BLOCKXSIZE=1024, BLOCKYSIZE=1024, RESOLUTIONS=6, PROGRESSION="RPCL",
                   **profile) as dst:
    dst.write(band, 1)
with rasterio.open(tif, "w", driver="GTiff", compress="lzw", tiled=True, **profile) as dst:
    dst.write(band, 1)


def timed_plan(raster):
    start = time.perf_counter()
    run = subprocess.run([imitate, "plan", raster, "--cells", "--start", "100,100",
                          "--goal", "102,103"], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    return time.perf_counter() - start


def timed_rasterio():
    start = time.perf_counter()
    with rasterio.Env(GDAL_NUM_THREADS="ALL_CPUS"):
        with rasterio.open(jp2) as src:
            values = src.read(1)
    assert (values == band).all()
    return time.perf_counter() - start


result = {
    "cells": n * n,
    "cores": os.cpu_count(),
    "imitate_plan_jp2_s": timed_plan(jp2),
    "imitate_plan_tif_s": timed_plan(tif),
    "rasterio_read_jp2_s": timed_rasterio(),
}
result["imitate_decode_s"] = result["imitate_plan_jp2_s"] - result["imitate_plan_tif_s"]
result["decode_ratio_to_openjpeg"] = result["imitate_decode_s"] / result["rasterio_read_jp2_s"]
print(json.dumps(result))
