"""Small rasters in CRSs that have no EPSG code, as GDAL writes them from PROJ strings
(user-defined GeoKeys: the projection method and its parameters), and points in
longitude and latitude with where PROJ puts them in each CRS. One JSON line per raster:
its file and [longitude, latitude, x, y] rows."""

import json
import os
import sys

import numpy as np
import rasterio
from rasterio.crs import CRS
from rasterio.transform import from_origin
from rasterio.warp import transform

out = sys.argv[1]
CRSS = {
    # North Carolina's State Plane cone on GRS80 with no datum, as nc_landsat7 has it.
    "lcc_2sp": ("+proj=lcc +lat_1=36.16666666666666 +lat_2=34.33333333333334 +lat_0=33.75 "
                "+lon_0=-79 +x_0=609601.22 +y_0=0 +ellps=GRS80 +units=m +no_defs",
                (-79.2, 35.6)),
    "lcc_1sp_feet": ("+proj=lcc +lat_1=45 +lat_0=45 +lon_0=-100 +k_0=0.9996 +x_0=500000 "
                     "+y_0=200000 +ellps=WGS84 +units=ft +no_defs", (-100.3, 45.2)),
    "tmerc": ("+proj=tmerc +lat_0=0 +lon_0=10.5 +k=0.9995 +x_0=300000 +y_0=-5000000 "
              "+ellps=WGS84 +units=m +no_defs", (10.9, 59.8)),
    "albers": ("+proj=aea +lat_1=20 +lat_2=60 +lat_0=40 +lon_0=-96 +x_0=0 +y_0=0 "
               "+ellps=GRS80 +units=m +no_defs", (-90.0, 38.0)),
    "laea": ("+proj=laea +lat_0=52 +lon_0=10 +x_0=4321000 +y_0=3210000 +ellps=GRS80 "
             "+units=m +no_defs", (12.0, 50.0)),
    "polar_stereo": ("+proj=stere +lat_0=-90 +lat_ts=-71 +lon_0=0 +x_0=0 +y_0=0 "
                     "+ellps=WGS84 +units=m +no_defs", (60.0, -75.0)),
    "sinusoidal": ("+proj=sinu +lon_0=0 +x_0=0 +y_0=0 +R=6371007.181 +units=m +no_defs",
                   (-93.5, 42.0)),
}
for name, (proj, (lon, lat)) in CRSS.items():
    crs = CRS.from_proj4(proj)
    (x,), (y,) = transform("EPSG:4326", crs, [lon], [lat])
    path = os.path.join(out, f"{name}.tif")
    cell = 100.0
    with rasterio.open(path, "w", driver="GTiff", width=20, height=20, count=1,
                       dtype="float32", crs=crs,
                       transform=from_origin(x - 10 * cell, y + 10 * cell, cell, cell)) as dst:
        dst.write(np.arange(400, dtype="float32").reshape(1, 20, 20) + 0.5)
    lons = [lon, lon + 0.004, lon - 0.003]
    lats = [lat, lat - 0.002, lat + 0.003]
    xs, ys = transform("EPSG:4326", crs, lons, lats)
    print(json.dumps({"name": name, "file": path,
                      "points": [list(p) for p in zip(lons, lats, xs, ys)]}))
