#!/usr/bin/env python3
"""Real DEMs from a package registry, as GeoTIFFs for `imitate bench terrain`.

matplotlib's wheel ships two real elevation grids in its sample data:
`jacksboro_fault_dem.npz` (a 3-arc-second, SRTM-like USGS DEM of the Jacksboro fault,
Tennessee: int16 metres, EPSG:4326, 1/1200° cells) and `topobathy.npz` (topography and
bathymetry off Vancouver Island: float32 metres on a 2-arc-minute longitude/latitude
grid). This script downloads the wheel with pip (no install), reads both, and writes
them with rasterio (GDAL) as north-up GeoTIFFs in EPSG:4326, ZSTD-compressed; and the
bathymetry as climate and ocean data come too, `topobathy.nc`: the GeoTIFF's grid as CF
netCDF-4 written by xarray, single-precision coordinates, longitudes 234–238 °E,
latitudes from the south, no grid mapping:

    python3 benches/terrain_dems.py OUT_DIR
    target/release/imitate bench terrain OUT_DIR/jacksboro_fault_dem.tif OUT_DIR/topobathy.tif

Needs rasterio and xarray (`scripts/python-deps.sh` installs them into
target/python-deps).
"""

import io
import os
import sys
import tempfile
import zipfile

import numpy as np
import rasterio
import wheels
from rasterio.transform import from_origin

out = sys.argv[1]
os.makedirs(out, exist_ok=True)
with tempfile.TemporaryDirectory() as tmp:
    wheel = wheels.download("matplotlib==3.11.2", tmp)
    with zipfile.ZipFile(wheel) as z:
        def sample(name):
            return np.load(io.BytesIO(z.read(f"matplotlib/mpl-data/sample_data/{name}")))
        dem = sample("jacksboro_fault_dem.npz")
        topo = sample("topobathy.npz")


def write(name, values, west, north, dx, dy):
    path = os.path.join(out, name + ".tif")
    profile = dict(driver="GTiff", width=values.shape[1], height=values.shape[0], count=1,
                   dtype=values.dtype, crs="EPSG:4326", compress="zstd",
                   transform=from_origin(west, north, dx, dy))
    with rasterio.open(path, "w", **profile) as dst:
        dst.write(values[np.newaxis])
    print(path)


# Row 0 is the north edge (`ymin` holds its latitude in this file).
z = dem["elevation"]
d = float(dem["dx"])
north = max(float(dem["ymin"]), float(dem["ymax"]))
write("jacksboro_fault_dem", z, float(dem["xmin"]) - d / 2, north + d / 2, d, d)

# Longitudes 234–238 °E are −126 to −122; latitudes grow with the row, so flip them.
lon, lat, t = topo["longitude"], topo["latitude"], topo["topo"]
dx, dy = float(lon[1] - lon[0]), float(lat[1] - lat[0])
values = t[::-1] if dy > 0 else t
write("topobathy", values.astype("float32"), float(lon[0]) - 360 - abs(dx) / 2,
      float(lat.max()) + abs(dy) / 2, abs(dx), abs(dy))

# The GeoTIFF's grid as xarray writes it: single-precision coordinates at the cells'
# centres, longitudes east of Greenwich (234–238 °E), latitudes from the south. (The
# file's own latitudes are even in Mercator y, not in degrees: GDAL gives them no grid,
# and imitate refuses them naming the first uneven one.)
import xarray as xr  # noqa: E402

rows = np.arange(len(lat))
even_lat = float(lat.max()) - abs(dy) * (len(lat) - 1 - rows)
even_lon = float(lon[0]) + abs(dx) * np.arange(len(lon))
xr.Dataset(
    {"elevation": (("lat", "lon"), (t if dy > 0 else t[::-1]).astype("float32"),
                   {"units": "m"})},
    coords={"lat": ("lat", even_lat.astype("float32"),
                    {"units": "degrees_north", "standard_name": "latitude"}),
            "lon": ("lon", even_lon.astype("float32"),
                    {"units": "degrees_east", "standard_name": "longitude"})},
).to_netcdf(os.path.join(out, "topobathy.nc"))
print(os.path.join(out, "topobathy.nc"))
