"""USGS ASCII DEMs as GDAL's USGSDEM driver writes them, and GTOPO30-style `.dem`
tiles (raw big-endian int16 beside an ESRI `.hdr`, GDAL's EHdr driver), each beside a
GeoTIFF twin of what GDAL reads it to. Prints one JSON line:

- `pairs` (twin, DEM): a 3-arc-second DEM in NAD83 degrees with voids; a 30 m DEM in
  UTM zone 15 on NAD83 (its quadrangle's corners widened to whole nodes); the same on
  WGS 84 with heights in tenths of a metre (`ZRESOLUTION`); a GTOPO30-style tile;
- `refused`: a file named `.dem` that is neither (an Esri ASCII grid).
"""

import json
import os
import sys

import numpy as np
import rasterio
import rasterio.shutil
from rasterio.transform import from_origin

from gdal_twin import twin

out = sys.argv[1]
rng = np.random.default_rng(21)
field = rng.normal(size=(60, 50)).cumsum(0).cumsum(1)


def path_of(name):
    return os.path.join(out, name)


def usgs(name, values, crs, transform, nodata=None, **options):
    source = path_of(name + ".tif")
    with rasterio.open(source, "w", driver="GTiff", width=values.shape[1],
                       height=values.shape[0], count=1, dtype=values.dtype, crs=crs,
                       transform=transform, nodata=nodata) as dst:
        dst.write(values, 1)
    rasterio.shutil.copy(source, path_of(name), driver="USGSDEM", **options)
    os.remove(source)
    return path_of(name)


heights = (field * 3 + 500).astype("int16")
voided = heights.copy()
voided[10:14, 20:30] = -32767
dems = [
    usgs("degrees.dem", voided, "EPSG:4269", from_origin(-105.0, 40.05, 1 / 1200, 1 / 1200),
         nodata=-32767),
    usgs("utm.dem", heights, "EPSG:26915", from_origin(500010.0, 4650000.0, 30, 30)),
    usgs("tenths.dem", (field * 3 + 500).astype("float32"), "EPSG:32615",
         from_origin(500010.0, 4650000.0, 30, 30), ZRESOLUTION="0.1"),
]

# As GTOPO30 tiles come: W100N40.DEM, big-endian int16 beside its .HDR.
gtopo = path_of("W100N40.DEM")
with rasterio.open(gtopo, "w", driver="EHdr", width=50, height=60, count=1,
                   dtype="int16", crs="EPSG:4326", nodata=-9999,
                   transform=from_origin(-100.0, 40.0, 1 / 120, 1 / 120)) as dst:
    dst.write(voided.astype("int16"), 1)

pairs = [twin(d) for d in dems + [gtopo]]
with open(path_of("grid.dem"), "w") as f:
    f.write("ncols 2\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 1\n1 2\n3 4\n")
print(json.dumps({"pairs": pairs, "refused": {"neither": path_of("grid.dem")}}))
