"""Rasters whose columns run west (a geotransform with a negative x step, as rioxarray
writes an array whose x coordinate descends), each beside a north-up, eastward GeoTIFF
of what GDAL reads it to: GDAL's array turned by NumPy (columns reversed, and rows where
they run from the south) on the same cells' grid. Prints one JSON line:

- `pairs` (eastward GeoTIFF, file): GeoTIFFs stepping west, north-up and south-up, a
  2-band one with nodata; an ERDAS Imagine file, a BIL beside its header and a PNG
  beside its world file stepping west; GDAL's VRT of the westward GeoTIFF.
"""

import json
import os
import sys

import numpy as np
import rasterio
import rasterio.shutil
from rasterio.transform import Affine

out = sys.argv[1]
rng = np.random.default_rng(21)
field = rng.normal(size=(2, 50, 70)).cumsum(1).cumsum(2)
east_edge, north_edge, size = 502_100.0, 4_600_000.0, 30.0


def path_of(name):
    return os.path.join(out, name)


def write(name, values, transform, driver="GTiff", **options):
    with rasterio.open(path_of(name), "w", driver=driver, width=values.shape[2],
                       height=values.shape[1], count=values.shape[0], dtype=values.dtype,
                       crs="EPSG:32618", transform=transform, **options) as dst:
        dst.write(values)
    return path_of(name)


def eastward_twin(path):
    """The north-up, eastward GeoTIFF of GDAL's reading of `path`: [twin, path]."""
    with rasterio.open(path) as src:
        values = src.read().astype("float32")
        values[src.read_masks() == 0] = np.nan
        t, crs, descriptions = src.transform, src.crs, src.descriptions
    assert t.b == 0 and t.d == 0, path
    west = t.c + t.a * values.shape[2] if t.a < 0 else t.c
    north = t.f + t.e * values.shape[1] if t.e > 0 else t.f
    if t.a < 0:
        values = values[:, :, ::-1]
    if t.e > 0:
        values = values[:, ::-1, :]
    twin = path + ".east.tif"
    with rasterio.open(twin, "w", driver="GTiff", width=values.shape[2],
                       height=values.shape[1], count=values.shape[0], dtype="float32",
                       crs=crs, transform=Affine(abs(t.a), 0, west, 0, -abs(t.e), north),
                       nodata=float("nan")) as dst:
        dst.write(np.ascontiguousarray(values))
        dst.descriptions = descriptions
    return [twin, path]


west = Affine(-size, 0, east_edge, 0, -size, north_edge)
heights = (field[:1] * 4 + 300).astype("float32")
image = (np.abs(field) * 9).astype("int16")
image[:, 10:14, 20:30] = -1
files = [
    write("west.tif", heights, west),
    write("west_south_up.tif", heights[:, ::-1, :].copy(),
          Affine(-size, 0, east_edge, 0, size, north_edge - 50 * size)),
    write("west_image.tif", image, west, nodata=-1, tiled=True, blockxsize=16,
          blockysize=16, compress="deflate"),
    write("west.img", heights, west, driver="HFA"),
    write("west.bil", image, west, driver="EHdr", nodata=-1),
    write("west_picture.png", (np.abs(field[:1]) * 3 % 250).astype("uint8"), west, driver="PNG",
          WORLDFILE="YES"),
]
rasterio.shutil.copy(path_of("west_image.tif"), path_of("west_image.vrt"), driver="VRT")
files.append(path_of("west_image.vrt"))

print(json.dumps({"pairs": [eastward_twin(path) for path in files]}))
