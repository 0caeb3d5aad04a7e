#!/usr/bin/env python3
"""Writes JPEG XL-compressed GeoTIFFs of real rasters for tests/geotiff_variants.rs.

    jpeg_xl.py SHARED_RASTER_DIR OUT_DIR

rasterio's GDAL is built without the JPEG XL codec, so tifffile writes the files, each
strip or tile a JPEG XL image from libjxl (imagecodecs) with its channels as GDAL lays
them out (grey or RGB, then the further bands as extra channels), with the TIFF code
GDAL and libtiff use (50002, or DNG 1.7's 52546). Beside each source, rasterio writes its
uncompressed baseline `<source>--none.tif`, whose GeoTIFF tags the JPEG XL files copy.
A lossy file has beside it what libjxl decodes from it, written uncompressed
(`libjxl-decoded--<name>.tif`). Prints one JSON line per JPEG XL file: name, the
baseline or decoded file it must read as, whether it is lossless.
"""

import json
import os
import sys

import imagecodecs
import numpy as np
import rasterio
import tifffile

src_dir, out = sys.argv[1], sys.argv[2]
os.makedirs(out, exist_ok=True)

# The GeoTIFF and GDAL tags a baseline's georeference and nodata live in.
GEO_TAGS = (33550, 33922, 34264, 34735, 34736, 34737, 42112, 42113)


def baseline(source, data, profile):
    """Writes `data` uncompressed with rasterio; returns its georeferencing tags."""
    p = dict(profile, driver="GTiff", compress=None, tiled=False, interleave="pixel",
             count=data.shape[0], dtype=data.dtype.name)
    for key in ("blockxsize", "blockysize"):
        p.pop(key, None)
    path = os.path.join(out, source + "--none.tif")
    with rasterio.open(path, "w", **p) as dst:
        dst.write(data)
    with tifffile.TiffFile(path) as tif:
        tags = tif.pages[0].tags
        return [(t.code, t.dtype, t.count, t.value, True)
                for t in (tags.get(code) for code in GEO_TAGS) if t is not None]


def write(name, reference, data, geo, lossless=True, planar=False, compression=50002,
          **args):
    """Writes bands × rows × columns `data` JPEG XL-compressed with tifffile."""
    bands = data.shape[0]
    pixels = data if planar else np.moveaxis(data, 0, -1)
    if bands == 1:
        pixels = data[0]
    photometric = "rgb" if bands >= 3 else "minisblack"
    extrasamples = [0] * (bands - 3) if bands > 3 else None
    path = os.path.join(out, name + ".tif")
    level = {"lossless": True} if lossless else {"distance": 1.0, "lossless": False}
    tifffile.imwrite(
        path, pixels, photometric=photometric,
        planarconfig="separate" if planar else "contig",
        extrasamples=extrasamples, compression=compression,
        compressionargs=level, extratags=geo, metadata=None, **args)
    if not lossless:
        reference = "libjxl-decoded--" + name
        decoded = tifffile.imread(path)
        decoded = decoded[None] if decoded.ndim == 2 else np.moveaxis(decoded, -1, 0)
        tifffile.imwrite(os.path.join(out, reference + ".tif"),
                         np.moveaxis(decoded, 0, -1) if bands > 1 else decoded[0],
                         photometric=photometric, extrasamples=extrasamples,
                         extratags=geo, metadata=None)
    print(json.dumps({"name": name, "reference": reference, "lossless": lossless}))


with rasterio.open(os.path.join(src_dir, "osgeo_spot_chicago_utm.tif")) as src:
    spot, spot_profile = src.read(), src.profile
with rasterio.open(os.path.join(src_dir, "rasterio_RGBA.uint16.tif")) as src:
    aerial, aerial_profile = src.read(), src.profile

# Grey 8-bit: tiles (edge tiles padded) and strips (the last one shorter).
geo = baseline("spot", spot, spot_profile)
write("spot--jxl-tiles", "spot--none", spot, geo, tile=(256, 256))
write("spot--jxl-strips", "spot--none", spot, geo, rowsperstrip=64)
# DNG 1.7's code for the same codestreams.
write("spot--jxl-dng", "spot--none", spot, geo, compression=52546, tile=(256, 256))

# Four 16-bit bands: RGB and an extra channel, or one grey image per band.
geo = baseline("aerial", aerial, aerial_profile)
write("aerial--jxl-tiles", "aerial--none", aerial, geo, tile=(128, 128))
write("aerial--jxl-planar", "aerial--none", aerial, geo, planar=True, tile=(128, 128))

# 32-bit floats with a NaN block (nodata), as a DEM or an index band comes.
heights = spot.astype(np.float32) * np.float32(0.37) - np.float32(12.5)
heights[:, :40, :50] = np.nan
geo = baseline("heights", heights, dict(spot_profile, nodata=np.nan))
write("heights--jxl-tiles", "heights--none", heights, geo, tile=(256, 256))

# Five 8-bit bands, pixel-interleaved, as GDAL lays out bands that are not RGB: a grey
# channel and four extra channels. tifffile's own encoder makes frames of them, so each
# strip is encoded here with libjxl and written as it is.
five = np.concatenate([spot, 255 - spot, spot // 2, spot // 3, 64 + spot // 4])
geo = baseline("five", five, spot_profile)
rows = 128
strips = (imagecodecs.jpegxl_encode(np.ascontiguousarray(five[:, r:r + rows]),
                                    planar=True, photometric="gray", lossless=True)
          for r in range(0, five.shape[1], rows))
tifffile.imwrite(os.path.join(out, "five--jxl-strips.tif"), strips,
                 shape=np.moveaxis(five, 0, -1).shape, dtype=five.dtype,
                 photometric="minisblack", planarconfig="contig", extrasamples=[0] * 4,
                 compression=50002, rowsperstrip=rows, extratags=geo, metadata=None)
print(json.dumps({"name": "five--jxl-strips", "reference": "five--none", "lossless": True}))

# Lossy RGB, as imagery is often stored: read as libjxl decodes it.
rgb = np.stack([spot[0], spot[0] // 2 + 60, 255 - spot[0]])
geo = baseline("rgb", rgb, spot_profile)
write("rgb--jxl-lossy", "rgb--none", rgb, geo, lossless=False, tile=(256, 256))
