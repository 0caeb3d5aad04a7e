"""The TIFFs the `geotiff` and `async-tiff` crates test themselves on (fetched by
scripts/sample-data.sh), copied to OUT, each beside a GeoTIFF twin of what GDAL reads it
to. Prints one JSON line:

- `pairs` (GeoTIFF twin, file) read losslessly: a Swiss DEM, an ETRS89-LAEA grid by
  tie point and scale or by transformation, as cells or as points, a Colombian grid of
  five bands; and the crates' plain TIFFs given a world file (`.tfw`), so that GDAL and
  imitate read them as maps: every sample type from 1-bit to 64-bit and half floats,
  predictors, PackBits, LZW (old-style too), ZSTD, palettes, min-is-white, CMYK (read
  as RGBA, as GDAL does), planar, tiled and BigTIFF in either byte order;
- `lossy`: the JPEG-compressed ones (two decoders may round differently);
- `mercator` [file, ground metres per projected metre at its centre]: a user-defined
  Mercator whose CRS GDAL cannot name, measured by PROJ from its GeoKeys;
- `refused` {what is wrong: file}: tie points with no scale (GCPs), no georeference,
  LogLuv samples.
"""

import glob
import json
import math
import os
import shutil
import sys
import warnings

import rasterio
from rasterio.warp import transform

from gdal_twin import twin

crate_tiffs, out = sys.argv[1], sys.argv[2]
warnings.simplefilter("ignore")
for path in glob.glob(os.path.join(crate_tiffs, "*.tif*")):
    shutil.copy(path, out)


def at(name):
    return os.path.join(out, name)


georeferenced = [
    "zh_dem_25.tif", "geo-5b.tif",
    "austrian_capitals_model_tie_point_and_pixel_scale_pixel_is_area.tif",
    "austrian_capitals_model_tie_point_and_pixel_scale_pixel_is_point.tif",
    "austrian_capitals_model_transformation_pixel_is_area.tif",
    "austrian_capitals_model_transformation_pixel_is_point.tif"]
lossy_names = ["tiled-jpeg-rgb-u8.tif", "tiled-jpeg-ycbcr.tif", "quad-tile.jpg.tiff"]
refused = {"control points": "austrian_capitals_model_tie_points_pixel_is_area.tif",
           "no georeference": "geogtowgs_subset_USGS_13_s14w171.tif",
           "photometric": "logluv-3c-16b.tiff"}
set_apart = set(georeferenced) | set(refused.values()) | {
    "merc.tif", "austrian_capitals_model_tie_points_pixel_is_point.tif"}
# Every other TIFF is a plain image: a world file makes it a map of 1 m cells.
plain = sorted(os.path.basename(p) for p in glob.glob(at("*.tif*"))
               if os.path.basename(p) not in set_apart)
for name in plain:
    with open(at(os.path.splitext(name)[0] + ".tfw"), "w") as f:
        f.write("1\n0\n0\n-1\n0.5\n1000.5\n")
pairs = [twin(at(name)) for name in georeferenced + plain if name not in lossy_names]
lossy = [twin(at(name)) for name in lossy_names]

# merc.tif's keys: Mercator (CT 7) about 90° W, scaled 0.8299 on the equator, false
# origin (0.001, 0.002), on NAD27's datum (Clarke 1866). GDAL names no CRS for it;
# PROJ measures 10 projected metres east of its centre.
with rasterio.open(at("merc.tif")) as src:
    left, bottom, right, top = src.bounds
x, y = (left + right) / 2, (bottom + top) / 2
mercator = ("+proj=merc +lon_0=-90 +k_0=0.829916312080482 +x_0=0.001 +y_0=0.002 "
            "+ellps=clrk66")
lon, lat = transform(mercator, "+proj=longlat +ellps=clrk66", [x, x + 10], [y, y])
a, f = 6378206.4, 1 / 294.978698213898
phi = math.radians(lat[0])
parallel = a * math.cos(phi) / math.sqrt(1 - f * (2 - f) * math.sin(phi) ** 2)
ground = math.radians(lon[1] - lon[0]) * parallel / 10

print(json.dumps({"pairs": pairs, "lossy": lossy, "mercator": [at("merc.tif"), ground],
                  "refused": {key: at(name) for key, name in refused.items()}}))
