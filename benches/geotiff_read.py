#!/usr/bin/env python3
"""GeoTIFF reading against GDAL: an 8000² uint16 DEM-like raster written by rasterio
four ways (tiled LZW with the horizontal predictor, LZW strips, tiled Deflate with the
predictor, tiled Deflate of 12-bit packed samples), then, in the same run, the best of three wall times of

  - `imitate plan RASTER --cells --start 4000,4000 --goal 4000,4001` for each binary
    given (the read, the costmap it makes of the band, a one-step plan, process start),
  - rasterio's `read(1)` of the same file (GDAL's decode into NumPy, in process).

    PYTHONPATH=target/python-deps python3 benches/geotiff_read.py OUT_DIR \\
        target/release/imitate [OTHER_IMITATE ...]

Needs rasterio (`scripts/python-deps.sh` installs it into target/python-deps).
"""

import os
import subprocess
import sys
import time

import numpy as np
import rasterio
from rasterio.transform import from_origin

out, binaries = sys.argv[1], sys.argv[2:]
os.makedirs(out, exist_ok=True)
n = 8000
rows, cols = np.mgrid[0:n, 0:n].astype("float32")
noise = np.random.default_rng(0).normal(0.0, 3.0, (n, n))
dem = (1000 + 300 * np.sin(cols / 700) * np.cos(rows / 900) + noise).astype("uint16")
profile = dict(driver="GTiff", width=n, height=n, count=1, dtype="uint16",
               crs="EPSG:32610", transform=from_origin(500000, 4200000, 1, 1))
layouts = {
    "lzw-tiled-pred2": dict(compress="lzw", predictor=2, tiled=True, blockxsize=512,
                            blockysize=512),
    "lzw-strips": dict(compress="lzw"),
    "deflate-tiled-pred2": dict(compress="deflate", predictor=2, tiled=True,
                                blockxsize=512, blockysize=512),
    # 12-bit samples packed (GDAL's NBITS=12): our own chunk reader and bit unpacker.
    "deflate-tiled-nbits12": dict(compress="deflate", nbits=12, tiled=True,
                                  blockxsize=512, blockysize=512),
}


def best_of_three(run):
    times = []
    for _ in range(3):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return min(times)


def gdal_read(path):
    with rasterio.open(path) as src:
        src.read(1)


print("| raster | " + " | ".join(binaries) + " | GDAL (rasterio) |")
print("|---" * (len(binaries) + 2) + "|")
for name, options in layouts.items():
    path = os.path.join(out, name + ".tif")
    if not os.path.exists(path):
        with rasterio.open(path, "w", **profile, **options) as dst:
            dst.write(dem, 1)
    cells = []
    for binary in binaries:
        command = [binary, "plan", path, "--cells", "--start", "4000,4000", "--goal",
                   "4000,4001"]
        seconds = best_of_three(
            lambda: subprocess.run(command, check=True, capture_output=True))
        cells.append(f"{seconds:.2f} s")
    gdal = best_of_three(lambda: gdal_read(path))
    print(f"| {name} | " + " | ".join(cells) + f" | {gdal:.2f} s |")
