#!/usr/bin/env python3
"""Writes GDAL (rasterio) variants of real rasters for tests/geotiff_variants.rs.

    geotiff_variants.py SHARED_RASTER_DIR OUT_DIR

For each source raster, every layout and compression GDAL users pick (strips, tiles,
BigTIFF, COG, band interleave; none, LZW, Deflate with predictors, PackBits, ZSTD, LERC,
JPEG for 8-bit imagery) as `<source>--<variant>.tif`, plus rasters that must be refused
(`bad--*.tif`). Prints one JSON line per file: name, source, whether it is lossless.
"""

import json
import os
import sys

import numpy as np
import rasterio
from rasterio.transform import Affine

src_dir, out = sys.argv[1], sys.argv[2]
os.makedirs(out, exist_ok=True)


def write(name, source, profile, data, lossless=True, **extra):
    p = dict(profile)
    p.update(extra)
    path = os.path.join(out, name + ".tif")
    with rasterio.open(path, "w", **p) as dst:
        dst.write(data)
    print(json.dumps({"name": name, "source": source, "lossless": lossless}))


def variants(source, path, jpeg=False):
    with rasterio.open(path) as src:
        data = src.read()
        profile = src.profile.copy()
    for key in ("compress", "predictor", "tiled", "blockxsize", "blockysize", "interleave",
                "photometric"):
        profile.pop(key, None)
    profile["driver"] = "GTiff"
    base = f"{source}--"
    write(base + "none", source, profile, data)
    write(base + "lzw", source, profile, data, compress="lzw")
    write(base + "deflate-pred2", source, profile, data, compress="deflate", predictor=2)
    write(base + "packbits", source, profile, data, compress="packbits")
    write(base + "zstd", source, profile, data, compress="zstd")
    write(base + "tiled-zstd", source, profile, data, compress="zstd", tiled=True,
          blockxsize=256, blockysize=256)
    write(base + "tiled-deflate", source, profile, data, compress="deflate", tiled=True,
          blockxsize=128, blockysize=128)
    write(base + "bigtiff-lzw", source, profile, data, compress="lzw", BIGTIFF="YES")
    write(base + "band-interleave", source, profile, data, compress="lzw",
          interleave="band")
    write(base + "lerc", source, profile, data, compress="lerc", MAX_Z_ERROR=0)
    write(base + "lerc-zstd-band", source, profile, data, compress="lerc_zstd",
          MAX_Z_ERROR=0, interleave="band", tiled=True, blockxsize=128, blockysize=128)
    cog = dict(profile)
    cog["driver"] = "COG"
    write(base + "cog", source, cog, data, compress="deflate", BLOCKSIZE=256,
          OVERVIEWS="AUTO")
    if jpeg:
        write(base + "jpeg", source, profile, data, lossless=False, compress="jpeg")
        # What GDAL itself decodes from that JPEG, stored losslessly to compare with.
        with rasterio.open(os.path.join(out, base + "jpeg.tif")) as src:
            decoded = src.read()
        path = os.path.join(out, "gdal-decoded--" + source + "-jpeg.tif")
        with rasterio.open(path, "w", **profile) as dst:
            dst.write(decoded)
    # A float copy of the first band with NaN nodata, Deflate's floating-point predictor.
    fp = dict(profile)
    fp.update(dtype="float32", count=1, nodata=float("nan"))
    band = data[:1].astype("float32")
    band[0, :3, :5] = np.nan
    write(base + "float-pred3", source, fp, band, compress="deflate", predictor=3)
    write(base + "float-lerc", source, fp, band, compress="lerc", MAX_Z_ERROR=0)
    write(base + "float-lerc-deflate", source, fp, band, compress="lerc_deflate",
          MAX_Z_ERROR=0, tiled=True, blockxsize=256, blockysize=256)


variants("aerial", os.path.join(src_dir, "rasterio_RGBA.uint16.tif"))
variants("spot", os.path.join(src_dir, "osgeo_spot_chicago_utm.tif"), jpeg=True)

# The SPOT image's numbers read as US survey feet (New York State Plane, EPSG:2263):
# the reader must turn its cells into metres.
with rasterio.open(os.path.join(src_dir, "osgeo_spot_chicago_utm.tif")) as src:
    data = src.read()
    profile = src.profile.copy()
feet = dict(profile)
feet.update(crs="EPSG:2263", compress="lzw")
write("units--us-feet", "units", feet, data)

# Rasters the reader must refuse, each for one reason.
with rasterio.open(os.path.join(src_dir, "osgeo_spot_chicago_utm.tif")) as src:
    data = src.read()
    profile = src.profile.copy()
rotated = dict(profile)
rotated["transform"] = Affine(10.0, 2.0, 440000.0, 2.0, -10.0, 4640000.0)
write("bad--rotated", "bad", rotated, data)
empty = dict(profile)
empty.update(nodata=0)
write("bad--all-nodata", "bad", empty, np.zeros_like(data))
