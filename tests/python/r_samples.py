"""The example rasters of R's raster, terra, stars and rgdal packages (fetched by
scripts/sample-data.sh), copied to OUT, each beside a GeoTIFF twin of what GDAL reads it
to. Prints one JSON line:

- `pairs` (GeoTIFF twin, raster): R-written `.grd` grids (their CRS a PROJ string: the
  Dutch RD grid, Mercator), GeoTIFFs (a Landsat 7 scene, DEMs, a land cover, the
  GeoTIFF project's samples: State Plane in feet, cylindrical equal-area), an Esri
  ASCII grid, an ENVI classification named `.envi`, a VRT of raw bands with a PROJ
  string as its SRS, scales and offsets;
- `variables` (GeoTIFF twin, netCDF file, variable): each variable GDAL reads of the
  netCDF files it georeferences, its steps as bands (a Lambert grid in km, 0–360°
  longitudes cut across Greenwich, sea-surface temperatures, climate projections,
  NASA's global 9 km chlorophyll map, nearly all of it nodata;
  xarray-spatial's Sentinel-2 bands, written by legacy xarray with the CRS as a `crs`
  attribute and an attribute named in Latin-1);
- and NASA's TRMM subset, which lies (lon, lat), beside a twin written from its values
  transposed (GDAL does not georeference it);
- `refused`: files imitate refuses, by what is wrong: a rotated GeoTIFF, stations
  rather than a grid, grids of 2-D latitudes and longitudes.
"""

import glob
import json
import os
import shutil
import sys
import warnings

import netCDF4
import numpy as np
import rasterio
from rasterio.transform import from_origin

from gdal_twin import twin

samples, out = sys.argv[1], sys.argv[2]
warnings.simplefilter("ignore")
for path in glob.glob(os.path.join(samples, "*", "*")):
    shutil.copy(path, os.path.join(out, os.path.basename(path)))


def at(name):
    return os.path.join(out, name)


def present(names):
    """The names of those files fetched (a Debian release may lack a package)."""
    return [name for name in names if os.path.exists(at(name))]


pairs = [twin(at(name)) for name in present([
    "test.grd", "rlogo.grd", "elev.tif", "logo.tif", "meuse.tif", "L7_ETMs.tif",
    "olinda_dem_utm25s.tif", "lc.tif", "na.tif", "SP27GTIF.TIF", "cea.tif",
    "erdas_spnad83.tif", "big_int_arc_file.asc", "test_envi_class.envi", "scaleoffset.vrt"])]
variables = []
# The CRS GDAL leaves out where the file gives it otherwise: xarray-spatial's bands keep
# theirs in a `crs` attribute, as legacy xarray wrote it; CF's is WGS 84 for latitudes
# and longitudes with no grid mapping.
given_crs = {"red_band.nc": "EPSG:32719", "nir_band.nc": "EPSG:32719"}
for name in present(["lcc_km.nc", "test_adaptor.cams_regional_fc.nc", "reduced.nc",
                      "bcsd_obs_1999.nc", "sub.nc", "red_band.nc", "nir_band.nc",
                      "S2008001.L3m_DAY_CHL_chlor_a_9km.nc"]):
    with rasterio.open(at(name)) as src:
        datasets = src.subdatasets or [at(name)]
    for dataset in datasets:
        variable = dataset.split(":")[-1] if dataset.startswith("netcdf:") else None
        # NASA's ocean-colour product keeps its colour table as a (rgb, colour)
        # variable of no grid, which GDAL lists and imitate rightly leaves out.
        if variable == "palette":
            continue
        with rasterio.open(dataset) as src:
            variable = variable or src.tags(1).get("NETCDF_VARNAME")
        tif = twin(dataset, at(f"{name}.{variable}.tif"))[0]
        with rasterio.open(tif, "r+") as dst:
            if dst.crs is None:
                dst.crs = given_crs.get(name, "EPSG:4326")
        variables.append([tif, at(name), variable])
# NASA's TRMM subset lies (lon, lat), which GDAL does not georeference: its twin is
# written from NetCDF4-python's reading, transposed, rows from the north.
for trmm in map(at, present(["3B42_Daily.19991231.7.test.nc"])):
    with netCDF4.Dataset(trmm) as ds:
        lon, lat = ds["lon"][:].astype(float), ds["lat"][:].astype(float)
        values = np.ma.filled(ds["precipitation"][:].astype("float32"), np.nan).T[::-1]
    with rasterio.open(trmm + ".tif", "w", driver="GTiff", width=len(lon), height=len(lat),
                       count=1, dtype="float32", crs="EPSG:4326", nodata=float("nan"),
                       transform=from_origin(lon[0] - 0.125, lat[-1] + 0.125, 0.25,
                                             0.25)) as dst:
        dst.write(values, 1)
        dst.descriptions = ["precipitation"]
        dst.units = ["mm"]
    pairs.append([trmm + ".tif", trmm])
refused = {key: at(name) for key, name in [
    ("rotated", "geomatrix.tif"), ("stations", "timeseries.nc"),
    ("curvilinear", "test_stageiv_xyt.nc")] if os.path.exists(at(name))}
print(json.dumps({"pairs": pairs, "variables": variables, "refused": refused}))
