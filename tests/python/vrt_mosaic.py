"""GDAL virtual rasters as gdalbuildvrt writes them (GDAL's own GDALBuildVRT, called from
the libgdal inside rasterio's wheel), each beside the GeoTIFF that GDAL (rasterio) reads
it to:

- a mosaic of three of four UTM DEM tiles with voids, the third overlapping the first
  (its voids must not hide the first's ground) and the fourth missing (nodata there);
- two SRTM tiles side by side (.hgt, 1201 x 1201, their shared edge column twice);
- three single-band files of three types stacked as bands (-separate);
- the mosaic at twice its cell size (-tr, nearest), and at 2.5 times it averaged
  (-r average: ComplexSources, voids left out);
- a float and an integer band shrunk to 40 % by gdal_translate -of VRT -r average
  (SimpleSources);
- the mosaic interpolated onto cells 2.5 times as small (-r bilinear, -r lanczos) and
  2.5 times as large (-r cubic, -r lanczos), and a float band grown to 170 %
  (-r cubicspline);
- a VRT of the mosaic's VRT;
- a raw file described by hand-written `VRTRawRasterBand`s (strides, byte orders, an
  EPSG code as its SRS).

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
gdal.GDALOpen.restype = ctypes.c_void_p
gdal.GDALOpen.argtypes = [ctypes.c_char_p, ctypes.c_int]
gdal.GDALTranslateOptionsNew.restype = ctypes.c_void_p
gdal.GDALTranslateOptionsNew.argtypes = [ctypes.c_void_p, ctypes.c_void_p]
gdal.GDALTranslate.restype = ctypes.c_void_p
gdal.GDALTranslate.argtypes = [ctypes.c_char_p, ctypes.c_void_p, ctypes.c_void_p,
                               ctypes.c_void_p]
gdal.GDALTranslateOptionsFree.argtypes = [ctypes.c_void_p]


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


def translate(name, source, *args):
    """gdal_translate's own code (GDALTranslate) from `source` to `name`."""
    path = os.path.join(out, name)
    opened = gdal.GDALOpen(source.encode(), 0)
    options = gdal.GDALTranslateOptionsNew(strings(list(args)), None)
    error = ctypes.c_int(0)
    dataset = gdal.GDALTranslate(path.encode(), opened, options, ctypes.byref(error))
    gdal.GDALTranslateOptionsFree(options)
    assert dataset and not error.value, f"GDALTranslate failed for {name}"
    gdal.GDALClose(dataset)
    gdal.GDALClose(opened)
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
averaged = buildvrt("averaged.vrt", tiles, "-tr", "25", "25", "-r", "average")
shrunk = [translate(f"shrunk{i}.vrt", bands[i], "-of", "VRT", "-outsize", "40%", "40%",
                    "-r", "average") for i in (0, 2)]
finer = buildvrt("bilinear.vrt", tiles, "-tr", "4", "4", "-r", "bilinear")
cubic = buildvrt("cubic.vrt", tiles, "-tr", "25", "25", "-r", "cubic")
lanczos = [buildvrt(f"lanczos{res}.vrt", tiles, "-tr", res, res, "-r", "lanczos")
           for res in ("4", "25")]
grown = translate("grown.vrt", bands[2], "-of", "VRT", "-outsize", "170%", "170%",
                  "-r", "cubicspline")
for vrt, kind in [(averaged, "ComplexSource"), (shrunk[0], "SimpleSource"),
                  (shrunk[1], "SimpleSource")]:
    with open(vrt) as f:
        text = f.read()
    assert f'<{kind} resampling="average"' in text, (vrt, text)
nested = buildvrt("nested.vrt", [mosaic])

# A raw file with no header of its own, described by a VRT written by hand (as SAR
# processors and users write them): two big-endian int16 bands interleaved by pixel
# after a 100-byte header, rows padded to 8 bytes more, nodata in the first; a float32
# band little-endian after them; the CRS an EPSG code, the file named in lowercase
# `relativetoVRT` as GDAL's own docs write it.
heights = (rng.normal(size=(2, 30, 40)).cumsum(1).cumsum(2) * 20).astype(">i2")
heights[0, 3:6, 4:9] = -9999
line = 40 * 2 * 2 + 8
raw = bytearray(100 + 30 * line)
for row in range(30):
    pixels = np.stack([heights[0, row], heights[1, row]], axis=1).tobytes()
    raw[100 + row * line:100 + row * line + len(pixels)] = pixels
floats = (rng.uniform(0, 1, size=(30, 40))).astype("<f4")
raw += floats.tobytes()
with open(os.path.join(out, "tiles", "scene.bin"), "wb") as f:
    f.write(bytes(raw))


def raw_band(number, dtype, offset, pixel, line, order, extra=""):
    return (f'<VRTRasterBand dataType="{dtype}" band="{number}" subClass="VRTRawRasterBand">'
            f'<SourceFilename relativetoVRT="1">tiles/scene.bin</SourceFilename>'
            f"<ImageOffset>{offset}</ImageOffset><PixelOffset>{pixel}</PixelOffset>"
            f"<LineOffset>{line}</LineOffset><ByteOrder>{order}</ByteOrder>{extra}"
            "</VRTRasterBand>")


raw_vrt = os.path.join(out, "raw.vrt")
with open(raw_vrt, "w") as f:
    f.write('<VRTDataset rasterXSize="40" rasterYSize="30"><SRS>EPSG:32633</SRS>'
            "<GeoTransform>500000, 10, 0, 5000000, 0, -10</GeoTransform>"
            + raw_band(1, "Int16", 100, 4, line, "MSB",
                       "<NoDataValue>-9999</NoDataValue>")
            + raw_band(2, "Int16", 102, 4, line, "MSB")
            + raw_band(3, "Float32", 100 + 30 * line, 4, 160, "LSB")
            + "</VRTDataset>")

# Each pair with the relative difference allowed: none where GDAL copies cells, a float's
# last bit where it averages them (its sums in another order than ours).
pairs = [[as_gdal_reads(v), v, 0.0] for v in (mosaic, srtm_vrt, stack, coarse, nested,
                                              raw_vrt, shrunk[0])]
pairs += [[as_gdal_reads(v), v, 1e-6]
          for v in (averaged, shrunk[1], finer, cubic, grown, *lanczos)]
print(json.dumps({"pairs": pairs, "tiles": os.path.join(out, "tiles")}))
