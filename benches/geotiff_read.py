#!/usr/bin/env python3
"""GeoTIFF reading against GDAL: an 8000² uint16 DEM-like raster written by rasterio
four ways (tiled LZW with the horizontal predictor, LZW strips, tiled Deflate with the
predictor, tiled Deflate of 12-bit packed samples) and by tifffile a fifth (tiled
lossless JPEG XL, which rasterio's GDAL has no codec for), then, in the same run, the
best of three wall times of

  - `imitate plan RASTER --cells --start 4000,4000 --goal 4000,4001` for each binary
    given (the read, the costmap it makes of the band, a one-step plan, process start),
  - rasterio's `read(1)` of the same file (GDAL's decode into NumPy, in process), or
    for JPEG XL tifffile's `imread` (libjxl through imagecodecs, a thread per core).

    PYTHONPATH=target/python-deps python3 benches/geotiff_read.py OUT_DIR \\
        target/release/imitate [OTHER_IMITATE ...]

Needs rasterio, tifffile and imagecodecs (`scripts/python-deps.sh` installs them into
target/python-deps).
"""

import os
import subprocess
import sys
import time

import numpy as np
import rasterio
import tifffile
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


def write_jxl(path):
    """The tiled Deflate file's pixels and GeoTIFF tags, tiles in lossless JPEG XL."""
    source = os.path.join(out, "deflate-tiled-pred2.tif")
    with tifffile.TiffFile(source) as tif:
        geo = [(t.code, t.dtype, t.count, t.value, True) for t in tif.pages[0].tags
               if t.code in (33550, 33922, 34735, 34736, 34737)]
    tifffile.imwrite(path, dem, photometric="minisblack", tile=(512, 512),
                     compression=50002, compressionargs={"lossless": True},
                     extratags=geo, metadata=None)


print("| raster | " + " | ".join(binaries) + " | GDAL (rasterio), or libjxl |")
print("|---" * (len(binaries) + 2) + "|")
for name, options in [*layouts.items(), ("jxl-tiled-lossless", None)]:
    path = os.path.join(out, name + ".tif")
    if not os.path.exists(path):
        if options is None:
            write_jxl(path)
        else:
            with rasterio.open(path, "w", **profile, **options) as dst:
                dst.write(dem, 1)
    cells = []
    for binary in binaries:
        command = [binary, "plan", path, "--cells", "--start", "4000,4000", "--goal",
                   "4000,4001"]
        seconds = best_of_three(
            lambda: subprocess.run(command, check=True, capture_output=True))
        cells.append(f"{seconds:.2f} s")
    if options is None:
        peer = best_of_three(lambda: tifffile.imread(path))
    else:
        peer = best_of_three(lambda: gdal_read(path))
    print(f"| {name} | " + " | ".join(cells) + f" | {peer:.2f} s |")
