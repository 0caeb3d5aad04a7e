"""SAGA GIS grids as GDAL writes them (its SAGA driver, through rasterio) and as SAGA
writes them, each beside a GeoTIFF twin of what they read to. Prints one JSON line:

- `pairs` (GeoTIFF twin, grid): GDAL-written grids of every sample type it writes (a
  float32 DEM in UTM with voids, int16 heights in degrees, uint8 classes, uint16, uint32,
  int32, float64), each named by its `.sdat` and one by its `.sgrd`; a header as SAGA 7
  writes it (keys in SAGA's order, `Z_OFFSET`, the nodata as a range of one value); the
  DEM as SAGA's compressed grid (`.sg-grd-z`); the twins are GDAL's reading of each;
- `saga_pairs` (twin, grid), where GDAL departs from SAGA and the twin is the values as
  SAGA reads them (NumPy, from the samples): rows stored from the top (`TOPTOBOTTOM`,
  which GDAL refuses), int16 samples with a z factor and offset (which GDAL ignores), a
  nodata range (GDAL masks its first value), the samples after a data file offset;
- `refused`: grids that are refused, by what is wrong: bits, text samples, a header
  missing, samples cut short.
"""

import json
import os
import shutil
import sys
import zipfile

import numpy as np
import rasterio
from rasterio.transform import from_origin

from gdal_twin import twin

out = sys.argv[1]
rng = np.random.default_rng(5)
field = rng.normal(size=(2, 70, 90)).cumsum(1).cumsum(2)


def path_of(name):
    return os.path.join(out, name)


def write(name, values, crs, transform, **options):
    with rasterio.open(path_of(name), "w", driver="SAGA", width=values.shape[1],
                       height=values.shape[0], count=1, dtype=values.dtype, crs=crs,
                       transform=transform, **options) as dst:
        dst.write(values, 1)
    return path_of(name)


def header(sdat):
    return os.path.splitext(sdat)[0] + ".sgrd"


def rewritten(source, name, samples, changes):
    """A copy of the grid `source` as `name`: `samples` (bytes) as its data file, its
    header with `changes` (key: value, None to drop the key) made."""
    target = path_of(name)
    with open(target, "wb") as f:
        f.write(samples)
    lines = []
    for line in open(header(source)).read().splitlines():
        key = line.split("=")[0].strip()
        if key in changes:
            if changes[key] is not None:
                lines.append(f"{key}\t= {changes[key]}")
        else:
            lines.append(line)
    lines += [f"{k}\t= {v}" for k, v in changes.items()
              if v is not None and not any(line.startswith(k + "\t") for line in lines)]
    open(header(target), "w").write("\n".join(lines) + "\n")
    shutil.copy(os.path.splitext(source)[0] + ".prj", os.path.splitext(target)[0] + ".prj")
    return target


def saga_twin(name, values, like):
    """A GeoTIFF of `values` (float32, NaN for nodata) on the grid of `like`."""
    with rasterio.open(like) as src:
        profile = dict(driver="GTiff", width=src.width, height=src.height, count=1,
                       dtype="float32", crs=src.crs, transform=src.transform,
                       nodata=float("nan"))
    target = path_of(name)
    with rasterio.open(target, "w", **profile) as dst:
        dst.write(values.astype("float32"), 1)
    return target


utm = from_origin(400020.0, 5200010.0, 10, 10)
degrees = from_origin(7.0, 47.0, 1 / 1200, 1 / 1200)
dem = (field[0] * 0.7 + 300).astype("float32")
dem[30:40, 10:25] = -99999
grids = [
    write("dem.sdat", dem, "EPSG:32632", utm, nodata=-99999),
    write("heights.sdat", (field[1] * 3 + 1500).astype("int16"), "EPSG:4326", degrees),
    write("classes.sdat", (np.abs(field[0]) % 7).astype("uint8"), "EPSG:32632", utm),
    write("counts.sdat", (np.abs(field[1]) * 40).astype("uint16"), "EPSG:32632", utm),
    write("large.sdat", (np.abs(field[1]) * 4e5).astype("uint32"), "EPSG:32632", utm),
    write("signed.sdat", (field[1] * 4e5).astype("int32"), "EPSG:32632", utm),
    write("double.sdat", field[0] * 0.01 + 12.5, "EPSG:32632", utm),
]
pairs = [twin(g) for g in grids]
pairs.append([pairs[0][0], header(grids[0])])

# As SAGA 7 and later write a header: their key order, Z_OFFSET, nodata as a range.
with open(grids[0], "rb") as f:
    samples = f.read()
saga_style = rewritten(grids[0], "saga_dem.sdat", samples, {
    "Z_OFFSET": "0.000000", "NODATA_VALUE": "-99999.000000;-99999.000000"})
pairs.append(twin(saga_style))

# SAGA's compressed grid: a ZIP of the three files.
compressed = path_of("dem_zipped.sg-grd-z")
with zipfile.ZipFile(compressed, "w", zipfile.ZIP_DEFLATED) as z:
    for extension in ("sgrd", "sdat", "prj"):
        z.write(os.path.splitext(grids[0])[0] + "." + extension, "dem_zipped." + extension)
pairs.append(twin(compressed))

# Where GDAL departs from SAGA: the twin holds the values as SAGA reads them.
with rasterio.open(grids[1]) as src:
    heights = src.read(1)
top_down = rewritten(grids[1], "top_down.sdat", heights.astype("<i2").tobytes(),
                     {"TOPTOBOTTOM": "TRUE"})
nodata = heights == -32767
scaled_values = np.where(nodata, np.nan, heights.astype("float64") * 0.25 + 100.0)
scaled = rewritten(grids[1], "scaled.sdat", heights[::-1].astype("<i2").tobytes(),
                   {"Z_FACTOR": "0.250000", "Z_OFFSET": "100.000000"})
low = np.percentile(heights, 20)
ranged = rewritten(grids[1], "ranged.sdat", heights[::-1].astype("<i2").tobytes(),
                   {"NODATA_VALUE": f"-32767.000000;{low:f}"})
offset = rewritten(grids[1], "offset.sdat", b"\0" * 64 + heights[::-1].astype(">i2").tobytes(),
                   {"DATAFILE_OFFSET": "64", "BYTEORDER_BIG": "TRUE"})
as_read = np.where(nodata, np.nan, heights.astype("float64"))
saga_pairs = [
    [saga_twin("top_down_twin.tif", as_read, grids[1]), top_down],
    [saga_twin("scaled_twin.tif", scaled_values, grids[1]), scaled],
    [saga_twin("ranged_twin.tif", np.where(heights <= low, np.nan, as_read), grids[1]), ranged],
    [saga_twin("offset_twin.tif", as_read, grids[1]), offset],
]

refused = {
    "bits": rewritten(grids[2], "bits.sdat", b"\0" * 1000, {"DATAFORMAT": "BIT"}),
    "text": rewritten(grids[2], "text.sdat", b"1 2 3\n", {"DATAFORMAT": "ASCII"}),
    "short": rewritten(grids[0], "short.sdat", samples[:1000], {}),
}
headless = path_of("headless.sdat")
shutil.copy(grids[0], headless)
refused["headless"] = headless
print(json.dumps({"pairs": pairs, "saga_pairs": saga_pairs, "refused": refused}))
