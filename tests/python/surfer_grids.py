"""Golden Software Surfer grids as GDAL writes them (its GSAG, GSBG and GS7BG drivers,
through rasterio): a float32 DEM in UTM with blanked nodes, as ASCII (`DSAA`), Surfer 6
binary (`DSBB`) and Surfer 7 binary (`DSRB`), each beside a GeoTIFF twin of what GDAL
reads it to; the CRS in GDAL's sidecar. Prints one JSON line: the pairs."""

import json
import os
import sys

import numpy as np
import rasterio
import rasterio.shutil
from rasterio.transform import from_origin

from gdal_twin import twin

out = sys.argv[1]
rng = np.random.default_rng(11)
dem = (rng.normal(size=(70, 90)).cumsum(0).cumsum(1) * 2 + 300).astype("float32")
dem[10:20, 30:50] = -9999
source = os.path.join(out, "dem.tif")
with rasterio.open(source, "w", driver="GTiff", width=90, height=70, count=1,
                   dtype="float32", crs="EPSG:32616",
                   transform=from_origin(440000, 4640000, 30, 20), nodata=-9999) as dst:
    dst.write(dem, 1)
pairs = []
for driver, name in [("GSAG", "dem_ascii.grd"), ("GSBG", "dem_surfer6.grd"),
                     ("GS7BG", "dem_surfer7.grd")]:
    path = os.path.join(out, name)
    rasterio.shutil.copy(source, path, driver=driver)
    pairs.append(twin(path))
print(json.dumps({"pairs": pairs}))
