#!/usr/bin/env python3
"""Writes small seeds for the `geotiff` fuzz target: a 40 × 28 cut of real rasters in
every layout, sample type and compression the reader decodes, by rasterio (GDAL) and,
for JPEG XL, tifffile with libjxl.

    PYTHONPATH=target/python-deps python3 fuzz/geotiff_seeds.py ../shared/data/raster OUT
"""

import os
import sys

import numpy as np
import rasterio
import tifffile
from rasterio.windows import Window

src_dir, out = sys.argv[1], sys.argv[2]
os.makedirs(out, exist_ok=True)


def cut(name, count=None):
    with rasterio.open(os.path.join(src_dir, name)) as src:
        window = Window(src.width // 3, src.height // 3, 40, 28)
        data = src.read(window=window)
        profile = dict(src.profile, width=40, height=28,
                       transform=src.window_transform(window))
    if count:
        data = data[:count]
        profile["count"] = count
    for key in ("blockxsize", "blockysize", "tiled", "compress", "interleave",
                "photometric"):
        profile.pop(key, None)
    return data, profile


def write(name, data, profile, **options):
    p = dict(profile, count=data.shape[0], dtype=data.dtype.name)
    p.update(options)
    with rasterio.open(os.path.join(out, name + ".tif"), "w", **p) as dst:
        dst.write(data)


grey, grey_profile = cut("osgeo_spot_chicago_utm.tif")
rgb8 = np.concatenate([grey, grey // 2, 255 - grey])
aerial, aerial_profile = cut("rasterio_RGBA.uint16.tif")
world, world_profile = cut("rasterio_world.byte.tif")
tiles = dict(tiled=True, blockxsize=16, blockysize=16)
for compress in ("none", "lzw", "deflate", "packbits", "zstd", "lzma", "lerc",
                 "lerc_zstd"):
    write(f"grey-{compress}", grey, grey_profile, compress=compress)
    write(f"aerial-{compress}-tiles", aerial, aerial_profile, compress=compress, **tiles)
for predictor in (2, 3):
    floats = grey.astype(np.float32) * 0.5 if predictor == 3 else grey.astype(np.int16)
    write(f"pred{predictor}", floats, grey_profile, compress="deflate",
          predictor=predictor, nodata=0)
write("planar", aerial, aerial_profile, interleave="band", compress="lzw", **tiles)
write("bigtiff", grey, grey_profile, BIGTIFF="YES", compress="deflate")
write("big-endian", aerial, aerial_profile, ENDIANNESS="BIG")
write("nbits12", aerial, aerial_profile, NBITS=12, compress="lzw")
write("nbits1", (grey > 100).astype(np.uint8), grey_profile, NBITS=1)
write("jpeg-ycbcr", rgb8, grey_profile, compress="jpeg", photometric="ycbcr", **tiles)
write("webp", rgb8, grey_profile, compress="webp", **tiles)
write("world-geographic", world, world_profile, compress="deflate")
write("float64-nan", np.where(grey > 200, np.nan, grey.astype(np.float64)),
      grey_profile, nodata=np.nan)

# JPEG XL, with the GeoTIFF tags of the uncompressed grey cut.
with tifffile.TiffFile(os.path.join(out, "grey-none.tif")) as tif:
    geo = [(t.code, t.dtype, t.count, t.value, True) for t in tif.pages[0].tags
           if t.code in (33550, 33922, 34735, 34736, 34737, 42113)]
for name, pixels, photometric in (("jxl-grey", grey[0], "minisblack"),
                                  ("jxl-rgb16", np.moveaxis(aerial[:3], 0, -1), "rgb")):
    tifffile.imwrite(os.path.join(out, name + ".tif"), pixels, photometric=photometric,
                     compression=50002, compressionargs={"lossless": True},
                     tile=(16, 16), extratags=geo, metadata=None)
