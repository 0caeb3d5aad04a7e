"""A land cover as CORINE ships it, and the same codes as a plain integer band: OUT/corine.tif
(uint8 with a colour table, codes 1 to 44 in patches, 48 where there is no data, 100 m
cells in LAEA Europe, EPSG:3035) and OUT/codes.tif (the same values, no colour table), with
OUT/demonstrations.parquet (three straight episodes across the raster, no map column, as
pyarrow writes a table). Then the same codes with GDAL's own sidecar (`.aux.xml`, written
by GDAL through its C API, from the library inside rasterio's wheel): OUT/labelled.tif with
a raster attribute table of values, counts and CORINE's class labels, and OUT/counted.tif
with values and counts alone, as ArcGIS builds for any integer raster. Prints one JSON
line per file."""

import ctypes
import glob
import json
import os
import sys

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import rasterio
from rasterio.transform import from_origin

out = sys.argv[1]
os.makedirs(out, exist_ok=True)
width, height, cell = 160, 120, 100.0
west, north = 4_300_000.0, 3_300_000.0

# Patches: each cell takes the code of its nearest of 300 seeded centres, every code of
# 1..44 given to some centre, so that all 44 classes are present.
rng = np.random.default_rng(44)
centres = rng.uniform([0, 0], [height, width], size=(300, 2))
codes = np.concatenate([np.arange(1, 45), rng.integers(1, 45, 300 - 44)])
rows, cols = np.mgrid[0:height, 0:width]
nearest = np.argmin(
    (rows[..., None] - centres[:, 0]) ** 2 + (cols[..., None] - centres[:, 1]) ** 2, axis=-1)
land_cover = codes[nearest].astype("uint8")
land_cover[:6, :20] = 48  # CORINE's "no data" code

profile = dict(driver="GTiff", width=width, height=height, count=1, dtype="uint8",
               crs="EPSG:3035", transform=from_origin(west, north, cell, cell), nodata=48,
               compress="lzw")
colours = {i: (int(37 * i) % 256, int(91 * i) % 256, int(53 * i) % 256, 255) for i in range(256)}
for name, palette in [("corine", True), ("codes", False), ("labelled", False),
                      ("counted", False)]:
    path = os.path.join(out, name + ".tif")
    with rasterio.open(path, "w", photometric="palette" if palette else "minisblack",
                       **profile) as dst:
        dst.write(land_cover[None])
        if palette:
            dst.write_colormap(1, colours)
    print(json.dumps({"file": path, "palette": palette}))

# Episodes from the west edge to the east edge along three rows, a pose per cell.
episode, t, x, y = [], [], [], []
for e, row in enumerate([30, 60, 90]):
    for c in range(5, width - 5):
        episode.append(f"drive-{e}")
        t.append(float(c))
        x.append(west + (c + 0.5) * cell)
        y.append(north - (row + 0.5) * cell)
path = os.path.join(out, "demonstrations.parquet")
pq.write_table(pa.table({"episode": episode, "t": t, "x": x, "y": y}), path)
print(json.dumps({"file": path}))


# GDAL's C API from the library rasterio's wheel carries (rasterio has no call for
# raster attribute tables).
gdal = ctypes.CDLL(glob.glob(os.path.join(os.path.dirname(rasterio.__file__), "..",
                                          "rasterio.libs", "libgdal*.so*"))[0])
P = ctypes.c_void_p
for function, restype, argtypes in [
        ("GDALOpen", P, [ctypes.c_char_p, ctypes.c_int]),
        ("GDALGetRasterBand", P, [P, ctypes.c_int]),
        ("GDALCreateRasterAttributeTable", P, []),
        ("GDALRATCreateColumn", ctypes.c_int, [P, ctypes.c_char_p, ctypes.c_int, ctypes.c_int]),
        ("GDALRATSetRowCount", None, [P, ctypes.c_int]),
        ("GDALRATSetValueAsInt", None, [P, ctypes.c_int, ctypes.c_int, ctypes.c_int]),
        ("GDALRATSetValueAsString", None, [P, ctypes.c_int, ctypes.c_int, ctypes.c_char_p]),
        ("GDALSetDefaultRAT", ctypes.c_int, [P, P]),
        ("GDALDestroyRasterAttributeTable", None, [P]),
        ("GDALClose", ctypes.c_int, [P])]:
    getattr(gdal, function).restype = restype
    getattr(gdal, function).argtypes = argtypes
GFT_INTEGER, GFT_STRING = 0, 2
GFU_GENERIC, GFU_PIXEL_COUNT, GFU_NAME, GFU_MIN_MAX = 0, 1, 2, 5
counts = np.bincount(land_cover.ravel(), minlength=45)
for name, labels in [("labelled", True), ("counted", False)]:
    path = os.path.join(out, name + ".tif")
    dataset = gdal.GDALOpen(path.encode(), 1)  # GA_Update
    band = gdal.GDALGetRasterBand(dataset, 1)
    table = gdal.GDALCreateRasterAttributeTable()
    gdal.GDALRATCreateColumn(table, b"Value", GFT_INTEGER, GFU_MIN_MAX)
    gdal.GDALRATCreateColumn(table, b"Count", GFT_INTEGER, GFU_PIXEL_COUNT)
    if labels:
        gdal.GDALRATCreateColumn(table, b"LABEL3", GFT_STRING, GFU_NAME)
    gdal.GDALRATSetRowCount(table, 44)
    for row in range(44):
        gdal.GDALRATSetValueAsInt(table, row, 0, row + 1)
        gdal.GDALRATSetValueAsInt(table, row, 1, int(counts[row + 1]))
        if labels:
            gdal.GDALRATSetValueAsString(table, row, 2, f"CLC class {row + 1}".encode())
    assert gdal.GDALSetDefaultRAT(band, table) == 0
    gdal.GDALDestroyRasterAttributeTable(table)
    gdal.GDALClose(dataset)
    assert os.path.exists(path + ".aux.xml"), path
    print(json.dumps({"file": path + ".aux.xml"}))
