"""GDAL virtual rasters as gdalbuildvrt writes them (GDAL's own GDALBuildVRT, called from
the libgdal inside rasterio's wheel), each beside the GeoTIFF that GDAL (rasterio) reads
it to:

- a mosaic of three of four UTM DEM tiles with voids, the third overlapping the first
  (its voids must not hide the first's ground) and the fourth missing (nodata there);
- two SRTM tiles side by side (.hgt, 1201 x 1201, their shared edge column twice);
- three single-band files of three types stacked as bands (-separate);
- the mosaic at twice its cell size (-tr, nearest);
- a VRT of the mosaic's VRT.

Prints one JSON line: the pairs (GeoTIFF as GDAL reads the VRT, the VRT) and the tiles'
folder."""

import ctypes
import glob
import json
import os
import sys

import numpy as np
import rasterio
import rasterio.shutil
from rasterio.transform import from_origin

out = sys.argv[1]
os.makedirs(os.path.join(out, "tiles"), exist_ok=True)

# GDALBuildVRT from the libgdal rasterio is linked to: gdalbuildvrt's own code.
libs = os.path.join(os.path.dirname(rasterio.__file__), "..", "rasterio.libs")
gdal = ctypes.CDLL(glob.glob(os.path.join(libs, "libgdal-*.so*"))[0])
gdal.GDALAllRegister()
gdal.GDALBuildVRTOptionsNew.restype = ctypes.c_void_p
gdal.GDALBuildVRTOptionsNew.argtypes = [ctypes.c_void_p, ctypes.c_void_p]
gdal.GDALBuildVRT.restype = ctypes.c_void_p
gdal.GDALBuildVRT.argtypes = [ctypes.c_char_p, ctypes.c_int, ctypes.c_void_p,
                              ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p]
gdal.GDALBuildVRTOptionsFree.argtypes = [ctypes.c_void_p]
gdal.GDALClose.argtypes = [ctypes.c_void_p]


def strings(items):
    return (ctypes.c_char_p * (len(items) + 1))(*[i.encode() for i in items], None)


def buildvrt(name, sources, *args):
    path = os.path.join(out, name)
    options = gdal.GDALBuildVRTOptionsNew(strings(list(args)), None)
    error = ctypes.c_int(0)
    dataset = gdal.GDALBuildVRT(path.encode(), len(sources), None, strings(sources), options,
                                ctypes.byref(error))
    gdal.GDALBuildVRTOptionsFree(options)
    assert dataset and not error.value, f"GDALBuildVRT failed for {name}"
    gdal.GDALClose(dataset)
    return path


def geotiff(path, values, crs, transform, nodata):
    values = values if values.ndim == 3 else values[None]
    with rasterio.open(path, "w", driver="GTiff", width=values.shape[2],
                       height=values.shape[1], count=values.shape[0], dtype=values.dtype,
                       crs=crs, transform=transform, nodata=nodata) as dst:
        dst.write(values)
    return path


def as_gdal_reads(vrt):
    """The VRT as GDAL reads it, written as a float GeoTIFF with NaN for nodata."""
    with rasterio.open(vrt) as src:
        values = np.stack([src.read(b, masked=True).astype("float32").filled(np.nan)
                           for b in src.indexes])
        return geotiff(vrt + ".tif", values, src.crs, src.transform, np.nan)


rng = np.random.default_rng(3)
dem = (800 + rng.normal(size=(100, 120)).cumsum(0) * 4).astype("float32")
tiles = []
for i, (row, col, rows, cols) in enumerate([(0, 0, 50, 60), (0, 60, 50, 60),
                                            (40, 0, 60, 60)]):
    part = dem[row:row + rows, col:col + cols].copy()
    part[5 + i:9 + i, 10:20] = -9999  # a void in every tile, the overlap's among them
    tiles.append(geotiff(os.path.join(out, "tiles", f"dem{i}.tif"), part, "EPSG:32633",
                         from_origin(500000 + 10 * col, 5000000 - 10 * row, 10, 10), -9999))
mosaic = buildvrt("mosaic.vrt", tiles)

half = 0.5 / 1200
srtm = []
for lon in (7, 8):
    # Heights that agree on the shared column: a function of longitude and latitude.
    r, c = np.mgrid[0:1201, 0:1201]
    tile = (400 + 300 * np.sin((lon + c / 1200) * 3) + (r % 97)).astype("int16")
    tile[300:310, 200:230] = -32768
    source = geotiff(os.path.join(out, "tiles", f"N46E00{lon}.tif"), tile, "EPSG:4326",
                     from_origin(lon - half, 47 + half, 1 / 1200, 1 / 1200), -32768)
    hgt = os.path.join(out, "tiles", f"N46E00{lon}.hgt")
    rasterio.shutil.copy(source, hgt, driver="SRTMHGT")
    srtm.append(hgt)
srtm_vrt = buildvrt("srtm.vrt", srtm)

bands = []
for i, dtype in enumerate(["uint8", "uint16", "float32"]):
    values = (rng.uniform(0, 200, size=(40, 50)) * (1 + 10 * i)).astype(dtype)
    bands.append(geotiff(os.path.join(out, "tiles", f"band{i}.tif"), values, "EPSG:32633",
                         from_origin(500000, 5000000, 10, 10), None))
stack = buildvrt("stack.vrt", bands, "-separate")
coarse = buildvrt("coarse.vrt", tiles, "-tr", "20", "20")
nested = buildvrt("nested.vrt", [mosaic])

pairs = [[as_gdal_reads(v), v] for v in (mosaic, srtm_vrt, stack, coarse, nested)]
print(json.dumps({"pairs": pairs, "tiles": os.path.join(out, "tiles")}))
