"""GeoTIFFs in projections imitate has no formula for (GDAL writes their GeoKeys by
method, or an EPSG code), each beside the ground metres per projected metre along x and
y at its centre as PROJ measures them (steps of a metre carried back to longitude and
latitude, measured on WGS 84). Prints one JSON line: [[file, [x, y]], ...]."""

import json
import math
import os
import sys

import numpy as np
import rasterio
from rasterio.transform import from_origin
from rasterio.warp import transform

out = sys.argv[1]
# (name, CRS, west edge, north edge): far enough from each projection's line or point
# of true scale that its metre is not a ground metre.
grids = [
    ("equidistant_cylindrical", "EPSG:4087", 1.0e6, 5.0e6),
    ("equidistant_conic", "+proj=eqdc +lat_1=30 +lat_2=60 +lat_0=45 +lon_0=0 +datum=WGS84",
     0.0, 0.0),
    ("robinson", "+proj=robin +lon_0=0 +datum=WGS84", 1.0e6, 5.0e6),
    ("orthographic", "+proj=ortho +lat_0=45 +lon_0=0 +datum=WGS84", 3.0e6, 3.0e6),
    ("stereographic", "+proj=stere +lat_0=45 +lon_0=0 +k=1 +datum=WGS84", 2.0e6, 2.0e6),
    ("azimuthal_equidistant", "+proj=aeqd +lat_0=45 +lon_0=0 +datum=WGS84", 2.0e6, 2.0e6),
    ("gnomonic", "+proj=gnom +lat_0=45 +lon_0=0 +datum=WGS84", 1.5e6, 1.5e6),
    ("polyconic", "+proj=poly +lat_0=0 +lon_0=0 +datum=WGS84", 2.0e6, 6.0e6),
]
values = np.arange(50 * 60, dtype="float32").reshape(50, 60)
a, e2 = 6378137.0, 0.00669437999014
expected = []
for name, crs, west, north in grids:
    path = os.path.join(out, name + ".tif")
    with rasterio.open(path, "w", driver="GTiff", width=60, height=50, count=1,
                       dtype="float32", crs=crs,
                       transform=from_origin(west, north, 100, 100)) as dst:
        dst.write(values, 1)
    x, y = west + 30 * 100, north - 25 * 100
    lon, lat = transform(crs, "EPSG:4326", [x, x + 1, x], [y, y, y + 1])
    phi = math.radians(lat[0])
    w = 1 - e2 * math.sin(phi) ** 2
    per_lon, per_lat = a / math.sqrt(w) * math.cos(phi), a * (1 - e2) / w ** 1.5
    step = [math.hypot(math.radians(lon[i] - lon[0]) * per_lon,
                       math.radians(lat[i] - lat[0]) * per_lat) for i in (1, 2)]
    expected.append([path, step])
print(json.dumps(expected))
