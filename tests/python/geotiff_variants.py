#!/usr/bin/env python3
"""Writes GDAL (rasterio) variants of real rasters for tests/geotiff_variants.rs.

    geotiff_variants.py SHARED_RASTER_DIR OUT_DIR

For each source raster, every layout and compression GDAL users pick (strips, tiles,
BigTIFF, COG, band interleave, big-endian; none, LZW, Deflate and LZMA with predictors,
PackBits, ZSTD, LERC, JPEG for 8-bit imagery) as `<source>--<variant>.tif`, plus rasters that must be refused
(`bad--*.tif`). Prints one JSON line per file: name, source, whether it is lossless.
"""

import json
import os
import sys

import numpy as np
import rasterio
from rasterio.transform import Affine

src_dir, out = sys.argv[1], sys.argv[2]
os.makedirs(out, exist_ok=True)


def write(name, source, profile, data, lossless=True, **extra):
    p = dict(profile)
    p.update(extra)
    path = os.path.join(out, name + ".tif")
    with rasterio.open(path, "w", **p) as dst:
        dst.write(data)
    print(json.dumps({"name": name, "source": source, "lossless": lossless}))


def variants(source, path, jpeg=False):
    with rasterio.open(path) as src:
        data = src.read()
        profile = src.profile.copy()
    for key in ("compress", "predictor", "tiled", "blockxsize", "blockysize", "interleave",
                "photometric"):
        profile.pop(key, None)
    profile["driver"] = "GTiff"
    base = f"{source}--"
    write(base + "none", source, profile, data)
    write(base + "lzw", source, profile, data, compress="lzw")
    write(base + "deflate-pred2", source, profile, data, compress="deflate", predictor=2)
    write(base + "packbits", source, profile, data, compress="packbits")
    write(base + "zstd", source, profile, data, compress="zstd")
    write(base + "tiled-zstd", source, profile, data, compress="zstd", tiled=True,
          blockxsize=256, blockysize=256)
    write(base + "tiled-deflate", source, profile, data, compress="deflate", tiled=True,
          blockxsize=128, blockysize=128)
    write(base + "bigtiff-lzw", source, profile, data, compress="lzw", BIGTIFF="YES")
    write(base + "band-interleave", source, profile, data, compress="lzw",
          interleave="band")
    # Edge tiles of tiled LZW, which the `tiff` crate's streaming LZW fails on.
    write(base + "tiled-lzw-pred2", source, profile, data, compress="lzw", predictor=2,
          tiled=True, blockxsize=128, blockysize=128)
    write(base + "bigendian-lzw-pred2", source, profile, data, compress="lzw", predictor=2,
          ENDIANNESS="BIG")
    write(base + "lzma", source, profile, data, compress="lzma")
    write(base + "tiled-lzma-pred2-band", source, profile, data, compress="lzma",
          predictor=2, tiled=True, blockxsize=128, blockysize=128, interleave="band")
    write(base + "lerc", source, profile, data, compress="lerc", MAX_Z_ERROR=0)
    write(base + "lerc-zstd-band", source, profile, data, compress="lerc_zstd",
          MAX_Z_ERROR=0, interleave="band", tiled=True, blockxsize=128, blockysize=128)
    cog = dict(profile)
    cog["driver"] = "COG"
    write(base + "cog", source, cog, data, compress="deflate", BLOCKSIZE=256,
          OVERVIEWS="AUTO")
    if jpeg:
        write(base + "jpeg", source, profile, data, lossless=False, compress="jpeg")
        # What GDAL itself decodes from that JPEG, stored losslessly to compare with.
        with rasterio.open(os.path.join(out, base + "jpeg.tif")) as src:
            decoded = src.read()
        path = os.path.join(out, "gdal-decoded--" + source + "-jpeg.tif")
        with rasterio.open(path, "w", **profile) as dst:
            dst.write(decoded)
    # A float copy of the first band with NaN nodata, Deflate's floating-point predictor.
    fp = dict(profile)
    fp.update(dtype="float32", count=1, nodata=float("nan"))
    band = data[:1].astype("float32")
    band[0, :3, :5] = np.nan
    write(base + "float-pred3", source, fp, band, compress="deflate", predictor=3)
    write(base + "float-lerc", source, fp, band, compress="lerc", MAX_Z_ERROR=0)
    write(base + "float-tiled-lzw-pred3", source, fp, band, compress="lzw", predictor=3,
          tiled=True, blockxsize=128, blockysize=128)
    write(base + "float-lzma-pred3-bigendian", source, fp, band, compress="lzma",
          predictor=3, ENDIANNESS="BIG")
    write(base + "float-lerc-deflate", source, fp, band, compress="lerc_deflate",
          MAX_Z_ERROR=0, tiled=True, blockxsize=256, blockysize=256)


# 8-bit RGB and RGBA images from the SPOT band (GDAL writes WebP for these only): the
# lossless WebP variants must read to the same samples, the lossy one is compared with
# what GDAL decodes from it. The alpha band is half-opaque on a block and opaque
# elsewhere (libwebp may rewrite the colour of fully transparent pixels).
def webp_variants(source, data, profile):
    profile = dict(profile, driver="GTiff", count=data.shape[0], dtype="uint8",
                   interleave="pixel")
    for key in ("compress", "predictor", "tiled", "blockxsize", "blockysize", "photometric",
                "nodata"):
        profile.pop(key, None)
    base = f"{source}--"
    write(base + "none", source, profile, data)
    write(base + "webp-lossless", source, profile, data, compress="webp",
          WEBP_LOSSLESS=True, tiled=True, blockxsize=256, blockysize=256)
    write(base + "webp-lossless-strips", source, profile, data, compress="webp",
          WEBP_LOSSLESS=True, blockysize=64)
    cog = dict(profile, driver="COG")
    write(base + "cog-webp-lossless", source, cog, data, compress="webp",
          QUALITY=100, BLOCKSIZE=256, OVERVIEWS="AUTO")
    write(base + "webp", source, profile, data, lossless=False, compress="webp",
          WEBP_LEVEL=80, tiled=True, blockxsize=256, blockysize=256)
    with rasterio.open(os.path.join(out, base + "webp.tif")) as src:
        decoded = src.read()
    with rasterio.open(os.path.join(out, f"gdal-decoded--{source}-webp.tif"), "w",
                       **profile) as dst:
        dst.write(decoded)


with rasterio.open(os.path.join(src_dir, "osgeo_spot_chicago_utm.tif")) as src:
    grey = src.read(1)
    spot_profile = src.profile.copy()
rgb = np.stack([grey, 255 - grey, grey // 2 + 60]).astype("uint8")
webp_variants("rgb8", rgb, spot_profile)
alpha = np.full_like(grey, 255)
alpha[100:300, 200:500] = 128
webp_variants("rgba8", np.concatenate([rgb, alpha[None]]), spot_profile)

variants("aerial", os.path.join(src_dir, "rasterio_RGBA.uint16.tif"))
variants("spot", os.path.join(src_dir, "osgeo_spot_chicago_utm.tif"), jpeg=True)

# The SPOT image's numbers read as US survey feet (New York State Plane, EPSG:2263):
# the reader must turn its cells into metres.
with rasterio.open(os.path.join(src_dir, "osgeo_spot_chicago_utm.tif")) as src:
    data = src.read()
    profile = src.profile.copy()
feet = dict(profile)
feet.update(crs="EPSG:2263", compress="lzw")
write("units--us-feet", "units", feet, data)
# Rotation terms of float noise (a transformation computed in floating point): the
# same grid as the SPOT image, not a rotated raster.
noise = dict(profile)
t = profile["transform"]
noise["transform"] = Affine(t.a, 1e-13, t.c, -1e-13, t.e, t.f)
write("units--rotation-noise", "units", noise, data)

# Rasters the reader must refuse, each for one reason.
with rasterio.open(os.path.join(src_dir, "osgeo_spot_chicago_utm.tif")) as src:
    data = src.read()
    profile = src.profile.copy()
rotated = dict(profile)
rotated["transform"] = Affine(10.0, 2.0, 440000.0, 2.0, -10.0, 4640000.0)
write("bad--rotated", "bad", rotated, data)
empty = dict(profile)
empty.update(nodata=0)
write("bad--all-nodata", "bad", empty, np.zeros_like(data))
# Complex samples (SAR): no map layer until their magnitude is taken.
complex_profile = dict(profile, dtype="complex64")
write("bad--complex", "bad", complex_profile, data.astype("complex64"))
# Ground control points and no grid (a scanned map or a raw scene before warping).
import warnings

import rasterio.errors
from rasterio.control import GroundControlPoint
from rasterio.crs import CRS as GcpCrs
unwarped = dict(profile)
unwarped.pop("transform", None)
unwarped.pop("crs", None)
with warnings.catch_warnings():
    warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
    dst = rasterio.open(os.path.join(out, "bad--gcps.tif"), "w", **unwarped)
with dst:
    dst.write(data)
    dst.gcps = ([GroundControlPoint(0, 0, 440000.0, 4640000.0),
                 GroundControlPoint(0, 100, 441000.0, 4640000.0),
                 GroundControlPoint(100, 0, 440000.0, 4639000.0)],
                GcpCrs.from_epsg(32616))
print(json.dumps({"name": "bad--gcps", "source": "bad", "lossless": True}))

# A DEM in UTM zone 10N (EPSG:32610) on its central meridian at 60° N, a plane rising
# 0.2 m per metre north and 0.1 east (slope atan √0.05 = 12.6°), and GDAL's warp of it
# into Web Mercator (EPSG:3857), whose "metres" span about cos 60° = 0.5 ground metres
# there: read in ground metres, both give the same slope.
from rasterio.warp import Resampling, calculate_default_transform, reproject

cells, size, west, south = 200, 30.0, 497000.0, 6650000.0
rows = np.arange(cells)[:, None]
cols = np.arange(cells)[None, :]
north = (cells - 1 - rows + 0.5) * size
east = (cols + 0.5) * size
plane = (0.2 * north + 0.1 * east + 100.0).astype(np.float32)
utm = dict(driver="GTiff", width=cells, height=cells, count=1, dtype="float32",
           crs="EPSG:32610", nodata=-9999.0,
           transform=Affine(size, 0.0, west, 0.0, -size, south + cells * size))
write("units--utm-plane", "units", utm, plane[None])
# The plane with infinities, as a ratio band holds where it divided by zero.
infinite = plane.copy()
infinite[:10, :] = np.inf
infinite[-3:, :5] = -np.inf
write("units--utm-plane-infinities", "units", utm, infinite[None])
bounds = (west, south, west + cells * size, south + cells * size)


def warped_plane(name, crs):
    """GDAL's bilinear warp of the UTM plane into `crs`."""
    transform, width, height = calculate_default_transform(
        "EPSG:32610", crs, cells, cells, *bounds)
    warped = np.full((height, width), -9999.0, dtype=np.float32)
    reproject(plane, warped, src_transform=utm["transform"], src_crs="EPSG:32610",
              src_nodata=-9999.0, dst_transform=transform, dst_crs=crs,
              dst_nodata=-9999.0, resampling=Resampling.bilinear)
    profile = dict(utm, crs=crs, transform=transform, width=width, height=height)
    write(name, "units", profile, warped[None])


warped_plane("units--web-mercator-plane", "EPSG:3857")
# NSIDC's Arctic grid (EPSG:3413, as ArcticDEM comes), true to scale at 70° N: at 60° N
# a projected metre spans 0.962 ground metres.
warped_plane("units--polar-stereographic-plane", "EPSG:3413")
# Equal-area grids stretch one axis by what they shrink the other. On the plane's
# meridian, far north of its standard parallels, an Albers cone's metre spans 0.902
# ground metres east and 1.108 north; the north polar LAEA's 0.966 and 1.035. GDAL
# writes both as user-defined projections with their parameters in the GeoKeys. Conus
# Albers (EPSG:5070, by its code) lies 27° off its meridian there: 0.920 and 1.093.
warped_plane("units--albers-plane",
             "+proj=aea +lat_1=29.5 +lat_2=45.5 +lat_0=23 +lon_0=-123 +datum=WGS84 +units=m")
warped_plane("units--laea-plane", "+proj=laea +lat_0=90 +lon_0=-123 +datum=WGS84 +units=m")
warped_plane("units--conus-albers-plane", "EPSG:5070")
# The world grids, where a degree of longitude away from the central meridian shears
# the axes apart: MODIS's sinusoidal grid (a sphere, user-defined keys with CT 24),
# EASE-Grid 2.0 (EPSG:6933, cylindrical, stretched 1.73 east at 60° N), Mollweide as
# GHSL comes (ESRI:54009: no GeoTIFF code, a user-defined model type and an ESRI PE
# string in the citation) and Equal Earth (EPSG:8857).
warped_plane("units--modis-sinusoidal-plane",
             "+proj=sinu +lon_0=0 +x_0=0 +y_0=0 +R=6371007.181 +units=m +no_defs")
warped_plane("units--ease2-plane", "EPSG:6933")
warped_plane("units--mollweide-plane", "ESRI:54009")
warped_plane("units--equal-earth-plane", "EPSG:8857")
# World maps on a sphere that PROJ carries and `proj4rs` does not: Eckert IV (ESRI's PE
# string in the citation), Van der Grinten (GeoTIFF's CT 25 keys; GDAL's authalic
# sphere), Winkel Tripel, Goode's interrupted homolosine as SoilGrids comes, and
# Kavrayskiy VII, which GeoTIFF cannot say: GDAL leaves its PROJ string in the sidecar.
warped_plane("units--eckert-iv-plane", "ESRI:54012")
warped_plane("units--van-der-grinten-plane", "ESRI:54029")
warped_plane("units--winkel-tripel-plane", "ESRI:54042")
warped_plane("units--goode-plane", "ESRI:54052")
warped_plane("units--kavrayskiy-plane", "+proj=kav7 +lon_0=0 +datum=WGS84 +units=m")
# A Lambert conformal cone with its standard parallels at 35° and 45° N, by its
# parameters: at 60° N its metre spans 0.936 ground metres both ways.
warped_plane("units--lcc-plane",
             "+proj=lcc +lat_1=35 +lat_2=45 +lat_0=40 +lon_0=-123 +datum=WGS84 +units=m")
# Transverse Mercator 24° east of the plane: UTM zone 14N (EPSG:32614, by its code),
# whose metre spans 0.9795 ground metres there, and a Gauss–Krüger-like grid on the
# same meridian by its parameters (k0 = 1, false easting 300 km): 0.9791.
warped_plane("units--utm-far-plane", "EPSG:32614")
warped_plane("units--tmerc-far-plane",
             "+proj=tmerc +lat_0=0 +lon_0=-99 +k=1 +x_0=300000 +y_0=0 +datum=WGS84 +units=m")

# The same plane stored as int16 decimetres above 100 m, with GDAL's scale 0.1 and
# offset 100 in its metadata: read as metres once scaled.
decimetres = dict(utm, dtype="int16", nodata=-32768)
path = os.path.join(out, "units--utm-plane-decimetres.tif")
with rasterio.open(path, "w", **decimetres) as dst:
    dst.write(np.round((plane - 100.0) * 10.0).astype("int16")[None])
    dst.scales = (0.1,)
    dst.offsets = (100.0,)
print(json.dumps({"name": "units--utm-plane-decimetres", "source": "units", "lossless": True}))

# The plane beside a second band, each with a band description as rasterio sets them
# (GDAL keeps them in its metadata tag): the layers are named by them.
path = os.path.join(out, "units--utm-plane-described.tif")
with rasterio.open(path, "w", **dict(utm, count=2)) as dst:
    dst.write(np.stack([plane, plane[::-1]]).astype(np.float32))
    dst.descriptions = ("Elevation (m)", "Near infrared & more")
print(json.dumps({"name": "units--utm-plane-described", "source": "units", "lossless": True}))

# The plane's heights in US survey feet under a compound CRS (UTM 10N + NAVD88 height
# (ftUS), as US LiDAR DEMs come): GDAL records the vertical CRS, and the heights read
# as metres.
from rasterio.crs import CRS

us_foot = 1200.0 / 3937.0
feet_heights = dict(utm, crs=CRS.from_string("EPSG:32610+6360"))
write("units--utm-plane-feet-navd88", "units", feet_heights,
      (plane / us_foot).astype(np.float32)[None])

# The plane's heights in US survey feet, said by the band's unit (rasterio's `units`,
# GDAL's unit type) and not by a vertical CRS: read as metres.
path = os.path.join(out, "units--utm-plane-feet-unittype.tif")
with rasterio.open(path, "w", **utm) as dst:
    dst.write((plane / us_foot).astype(np.float32)[None])
    dst.units = ("US survey foot",)
print(json.dumps({"name": "units--utm-plane-feet-unittype", "source": "units", "lossless": True}))

# Rasters as data comes, each with GDAL's own reading of it beside it
# (`expected--<name>.tif`: float32, NaN wherever GDAL masks a cell): palette land-cover
# classes, 1-bit masks, sparse files whose all-nodata tiles are left out, imagery with
# an internal nodata mask, and float DEMs whose nodata is -FLT_MAX as GDAL writes it.
def with_gdal_reading(name, profile, data, lossless=True, mask=None, colormap=None,
                      env=None, **extra):
    p = dict(profile, driver="GTiff", count=data.shape[0], dtype=data.dtype.name)
    p.update(extra)
    path = os.path.join(out, name + ".tif")
    with rasterio.Env(**(env or {})):
        with rasterio.open(path, "w", **p) as dst:
            dst.write(data)
            if colormap is not None:
                dst.write_colormap(1, colormap)
            if mask is not None:
                dst.write_mask(mask)
    with rasterio.open(path) as src:
        read = src.read(masked=True).astype("float32").filled(np.nan)
        # A file with an internal mask reads it per band; nodata likewise.
    expected = dict(profile, driver="GTiff", count=data.shape[0], dtype="float32",
                    nodata=float("nan"))
    for key in ("compress", "predictor", "tiled", "blockxsize", "blockysize",
                "photometric", "nbits", "interleave"):
        expected.pop(key, None)
    with rasterio.open(os.path.join(out, "expected--" + name + ".tif"), "w",
                       **expected) as dst:
        dst.write(read)
    print(json.dumps({"name": name, "source": "kinds", "lossless": lossless}))


kinds = dict(spot_profile)
for key in ("compress", "predictor", "tiled", "blockxsize", "blockysize", "photometric",
            "nodata", "interleave"):
    kinds.pop(key, None)
classes = (grey // 43).astype("uint8")[None]
palette = {i: (40 * i % 256, 255 - 40 * i % 256, 90, 255) for i in range(256)}
with_gdal_reading("kinds--palette", kinds, classes, photometric="palette",
                  colormap=palette)
with_gdal_reading("kinds--palette-tiled-lzw", kinds, classes, photometric="palette",
                  colormap=palette, compress="lzw", tiled=True, blockxsize=128,
                  blockysize=128)
bright = (grey > 100).astype("uint8")[None]
with_gdal_reading("kinds--bits1", kinds, bright, nbits=1)
with_gdal_reading("kinds--bits1-tiled-deflate", kinds, bright, nbits=1, compress="deflate",
                  tiled=True, blockxsize=128, blockysize=128)
with_gdal_reading("kinds--bits4", kinds, classes, nbits=4, compress="packbits")
# GDAL's NBITS widths past a byte (12-bit imagery as satellite products pack it, 20-bit
# counts, band-interleaved too), 3-bit classes, and Float32 stored as half floats
# (NBITS=16) under the floating-point predictor.
twelve = (grey.astype("uint16") * 16 + grey.astype("uint16") % 13)[None]
with_gdal_reading("kinds--bits12-lzw", kinds, twelve, nbits=12, compress="lzw")
with_gdal_reading("kinds--bits12-tiled-deflate", kinds,
                  np.concatenate([twelve, 4095 - twelve]), nbits=12, compress="deflate",
                  tiled=True, blockxsize=128, blockysize=128, interleave="band")
with_gdal_reading("kinds--bits20-zstd", kinds, (grey.astype("uint32") * 4099)[None],
                  nbits=20, compress="zstd")
with_gdal_reading("kinds--bits3-packbits", kinds, (grey // 37).astype("uint8")[None],
                  nbits=3, compress="packbits")
# Floats under the horizontal predictor (GDAL differences their bit patterns as
# integers when asked for PREDICTOR=2), through our LZW reader and the crate's Deflate.
for compress in ("lzw", "deflate"):
    with_gdal_reading(f"kinds--float-{compress}-predictor2", kinds,
                      np.stack([grey.astype("float32") / 3.0 - 40.0,
                                np.sqrt(grey.astype("float32"))]),
                      compress=compress, predictor=2)
with_gdal_reading("kinds--half-lzw-predictor3", kinds,
                  ((grey.astype("float32") - 128.0) / 7.0)[None], nbits=16,
                  compress="lzw", predictor=3)
# Every sample type GDAL writes, under the predictor that suits it (DEMs come as int16
# and float64, counts as 32- and 64-bit integers, GDAL 3.7's Int8), in either byte order.
signed = grey.astype("int64") - 128
for dtype, predictor, extra in [("int8", 2, {}), ("int16", 2, {"ENDIANNESS": "BIG"}),
                                ("uint32", 2, {}), ("int32", 2, {"ENDIANNESS": "BIG"}),
                                ("int64", 2, {}), ("uint64", 2, {}),
                                ("float64", 3, {}), ("float64", 3, {"ENDIANNESS": "BIG"})]:
    scale = {"int8": 1, "int16": 97, "uint32": 65537, "int32": -65537, "int64": 3,
             "uint64": 5, "float64": 0.001}[dtype]
    values = (grey.astype("int64") * scale if dtype.startswith("u") else signed * scale)
    suffix = "-bigendian" if extra else ""
    with_gdal_reading(f"kinds--{dtype}-deflate-predictor{predictor}{suffix}", kinds,
                      values.astype(dtype)[None], compress="deflate", predictor=predictor,
                      **extra)
voids = grey[None].astype("float32")
voids[0, : voids.shape[1] // 2, : voids.shape[2] // 2] = -9999.0
for compress in ("none", "deflate"):
    with_gdal_reading(f"kinds--sparse-{compress}", kinds, voids, nodata=-9999.0,
                      compress=compress, tiled=True, blockxsize=128, blockysize=128,
                      SPARSE_OK=True)
# -FLT_MAX voids under the nodata value ArcGIS writes (and GDAL reads as -FLT_MAX):
# 12 digits, not f32::MIN as a double.
flt_max = voids.copy()
flt_max[flt_max == -9999.0] = np.finfo(np.float32).min
with_gdal_reading("kinds--nodata-flt-max", kinds, flt_max, nodata=-3.40282346639e+38,
                  compress="lzw")
coverage = np.full(grey.shape, 255, dtype="uint8")
coverage[:, : grey.shape[1] // 3] = 0
coverage[200:260, 300:420] = 0
internal = {"GDAL_TIFF_INTERNAL_MASK": True}
with_gdal_reading("kinds--masked-deflate", kinds, rgb, mask=coverage, env=internal,
                  compress="deflate", tiled=True, blockxsize=256, blockysize=256)
# A float raster in strips, LZW, band-interleaved, with its mask in strips too (as
# rasterstats' test data ships one): masks compressed as their image is.
with_gdal_reading("kinds--masked-float-lzw", kinds, voids, mask=coverage, env=internal,
                  compress="lzw", interleave="band")
# JPEG imagery as GDAL writes it, YCbCr with chroma subsampled, on colours that follow
# the brightness as a photograph's do (the SPOT band and its 5-cell mean), with the
# uncompressed colours beside it to measure both decoders against.
box = np.ones(5) / 5
smooth = np.apply_along_axis(np.convolve, 1, grey.astype(float), box, "same")
smooth = np.apply_along_axis(np.convolve, 0, smooth, box, "same")
photo = np.stack([grey, 0.7 * grey + 0.27 * smooth + 10, 0.5 * smooth + 60])
photo = photo.clip(0, 255).astype("uint8")
with rasterio.open(os.path.join(out, "source--kinds--masked-jpeg.tif"), "w",
                   **dict(kinds, driver="GTiff", count=3, dtype="uint8")) as dst:
    dst.write(photo)
with_gdal_reading("kinds--masked-jpeg", kinds, photo, lossless=False, mask=coverage,
                  env=internal, compress="jpeg", photometric="ycbcr", tiled=True,
                  blockxsize=256, blockysize=256)
# An orthomosaic as OpenDroneMap writes one: RGBA, alpha 0 outside the survey.
survey = np.full(grey.shape, 255, dtype="uint8")
survey[:, : grey.shape[1] // 4] = 0
survey[-50:, :] = 0
with_gdal_reading("kinds--rgba-alpha", kinds, np.concatenate([photo, survey[None]]),
                  photometric="rgb", ALPHA="YES", compress="deflate",
                  tiled=True, blockxsize=256, blockysize=256)

# Georeferenced outside the TIFF, as GDAL writes a baseline TIFF (`PROFILE=BASELINE`:
# no GeoTIFF tags; the CRS and geotransform in its `.aux.xml`), and with a world file
# alone (`TFW=YES`, the `.aux.xml` taken away: a scanned map's or an old tool's TIFF).
for source, file in [("spot", "osgeo_spot_chicago_utm.tif"), ("world", "rasterio_world.byte.tif")]:
    with rasterio.open(os.path.join(src_dir, file)) as src:
        data = src.read()
        profile = dict(src.profile, driver="GTiff")
    for key in ("compress", "predictor", "tiled", "blockxsize", "blockysize", "interleave",
                "photometric"):
        profile.pop(key, None)
    write(f"{source}--reference", "sidecars", profile, data)
    write(f"{source}--baseline-pam", "sidecars", profile, data, PROFILE="BASELINE")
    name = f"{source}--baseline-tfw"
    write(name, "sidecars", profile, data, PROFILE="BASELINE", TFW="YES")
    os.remove(os.path.join(out, name + ".tif.aux.xml"))
    assert os.path.exists(os.path.join(out, name + ".tfw"))

# The sidecar before the TIFF's own georeference, as GDAL reads them (its
# GDAL_GEOREF_SOURCES: PAM, then the GeoTIFF tags, then a world file): a georeferenced
# TIFF whose `.aux.xml` moves it (GDAL writes one there when it may not change the TIFF),
# and a baseline TIFF whose `.aux.xml` gives a CRS in US survey feet as PROJ's WKT 2, the
# unit in its axes. What GDAL reads of each is printed beside it.
from rasterio.crs import CRS  # noqa: E402

with rasterio.open(os.path.join(src_dir, "osgeo_spot_chicago_utm.tif")) as src:
    data = src.read()
    profile = dict(src.profile, driver="GTiff")
    t = src.transform
for key in ("compress", "predictor", "tiled", "blockxsize", "blockysize", "interleave",
            "photometric"):
    profile.pop(key, None)
moved = [t.c + 1000.0, t.a, t.b, t.f - 500.0, t.d, t.e]
for name, extra, srs in [
    ("spot--pam-moves-it", {}, None),
    ("spot--pam-wkt2-feet", {"PROFILE": "BASELINE"},
     CRS.from_epsg(2263).to_wkt(version="WKT2_2019")),
]:
    path = os.path.join(out, name + ".tif")
    with rasterio.open(path, "w", **dict(profile, **extra)) as dst:
        dst.write(data)
    pam = "<PAMDataset>\n"
    if srs is not None:
        pam += "  <SRS>" + srs.replace("&", "&amp;").replace('"', "&quot;") + "</SRS>\n"
    pam += "  <GeoTransform>" + ", ".join(repr(v) for v in moved) + "</GeoTransform>\n"
    pam += "</PAMDataset>\n"
    with open(path + ".aux.xml", "w") as f:
        f.write(pam)
    with rasterio.open(path) as src:
        gdal = {"transform": list(src.transform)[:6], "epsg": src.crs.to_epsg(),
                "metres_per_unit": src.crs.linear_units_factor[1]}
    print(json.dumps({"name": name, "source": "pam-first", "lossless": True, "gdal": gdal}))

# Baseline TIFFs whose `.aux.xml` gives the CRS in ESRI's WKT, with no EPSG code, as
# ArcGIS writes it: a UTM zone (known by ESRI's name), a State Plane grid in US survey
# feet and Conus Albers (known by their parameters). Beside each, the same grid as a
# GeoTIFF with the CRS's EPSG code in its GeoKeys, and what GDAL reads of the sidecar.
# And Conus Albers by its parameters alone in WKT 2, as PROJ writes a CRS with no code.
conus_wkt2 = CRS.from_string("+proj=aea +lat_1=29.5 +lat_2=45.5 +lat_0=23 +lon_0=-96 "
                             "+datum=NAD83 +units=m +no_defs").to_wkt(version="WKT2_2019")
assert conus_wkt2.startswith('PROJCRS["unknown"') and 'ID["EPSG",5070]' not in conus_wkt2
for name, code, esri in [
    ("utm", 32616, CRS.from_epsg(32616).to_wkt(version="WKT1_ESRI")),
    ("feet", 2263, CRS.from_epsg(2263).to_wkt(version="WKT1_ESRI")),
    ("albers", 5070, CRS.from_epsg(5070).to_wkt(version="WKT1_ESRI")),
    ("wkt2-albers", 5070, conus_wkt2),
]:
    path = os.path.join(out, f"spot--pam-esri-{name}.tif")
    with rasterio.open(path, "w", **dict(profile, PROFILE="BASELINE")) as dst:
        dst.write(data)
    assert "AUTHORITY" not in esri
    with open(path + ".aux.xml", "w") as f:
        f.write("<PAMDataset>\n  <SRS>" + esri.replace("&", "&amp;").replace('"', "&quot;")
                + "</SRS>\n  <GeoTransform>" + ", ".join(repr(v) for v in moved)
                + "</GeoTransform>\n</PAMDataset>\n")
    reference = dict(profile, crs=CRS.from_epsg(code), transform=Affine.from_gdal(*moved))
    with rasterio.open(os.path.join(out, f"spot--esri-{name}-reference.tif"), "w",
                       **reference) as dst:
        dst.write(data)
    with rasterio.open(path) as src:
        gdal = {"transform": list(src.transform)[:6],
                "metres_per_unit": src.crs.linear_units_factor[1]}
    print(json.dumps({"name": f"spot--pam-esri-{name}", "source": "pam-esri", "lossless": True,
                      "gdal": gdal, "epsg": code}))

# A DEM in a compound CRS, as GDAL writes a baseline TIFF's: the sidecar's COMPD_CS of a
# State Plane CRS in US survey feet and NAVD88 heights in US survey feet (EPSG:2263+6360).
heights = (data[:1].astype("float32") * 3.0 + 100.0)
dem = dict(profile, count=1, dtype="float32", nodata=None, crs="EPSG:2263+6360",
           transform=Affine(10.0, 0.0, 1000000.0, 0.0, -10.0, 200000.0), PROFILE="BASELINE")
path = os.path.join(out, "dem--pam-compound-feet.tif")
with rasterio.open(path, "w", **dem) as dst:
    dst.write(heights)
with rasterio.open(path) as src:
    gdal = {"transform": list(src.transform)[:6], "metres_per_unit": src.crs.linear_units_factor[1],
            "first_value": float(src.read(1)[0, 0])}
assert "COMPD_CS" in open(path + ".aux.xml").read()
print(json.dumps({"name": "dem--pam-compound-feet", "source": "pam-compound", "lossless": True,
                  "gdal": gdal}))

import struct


def drop_geokey(path, key_id):
    """Removes one GeoKey from a little-endian classic TIFF's GeoKeyDirectory."""
    with open(path, "r+b") as f:
        tiff = bytearray(f.read())
        assert tiff[:4] == b"II*\x00"
        ifd = struct.unpack_from("<I", tiff, 4)[0]
        for i in range(struct.unpack_from("<H", tiff, ifd)[0]):
            entry = ifd + 2 + 12 * i
            tag, kind, count, offset = struct.unpack_from("<HHII", tiff, entry)
            if tag == 34735:
                keys = list(struct.unpack_from(f"<{count}H", tiff, offset))
                entries = [keys[j:j + 4] for j in range(4, count, 4)]
                kept = [k for k in entries if k[0] != key_id]
                assert len(kept) == len(entries) - 1
                shorter = keys[:3] + [len(kept)] + [v for k in kept for v in k]
                struct.pack_into(f"<{len(shorter)}H", tiff, offset, *shorter)
                struct.pack_into("<I", tiff, entry + 4, len(shorter))
        f.seek(0)
        f.write(tiff)


# Grids by EPSG codes the reader knows only from the EPSG registry (State Plane grids in
# US and international feet, polar stereographic grids on Hughes 1980, national Lambert
# and Transverse Mercator grids), each centred on a place within its area, its
# ProjLinearUnits key taken out (so that the code alone gives its unit), beside the
# ground metres per projected unit along x and y that GDAL's transformations give there
# (a small step each way, measured on the ellipsoid).
import math

from rasterio.warp import transform as warp_transform


def ground_metres(lon, lat, dlon, dlat):
    """Metres on WGS 84 of a small step (degrees) at (lon, lat)."""
    a, e2 = 6378137.0, 6.69437999014e-3
    phi = math.radians(lat)
    w = 1.0 - e2 * math.sin(phi) ** 2
    east = a / math.sqrt(w) * math.cos(phi) * math.radians(dlon)
    north = a * (1.0 - e2) / w ** 1.5 * math.radians(dlat)
    return math.hypot(east, north)


for code, lon, lat in [(2263, -73.8, 40.7), (2227, -121.5, 37.5), (3435, -88.0, 41.8),
                       (2868, -111.9, 33.4), (3411, -45.0, 62.0), (3412, 0.0, -62.0),
                       (2180, 19.0, 52.0), (32198, -70.0, 62.0), (3111, 145.0, -37.0),
                       (6372, -102.0, 23.0), (2039, 35.0, 31.5), (3400, -115.0, 55.0)]:
    crs = CRS.from_epsg(code)
    (x,), (y,) = warp_transform("EPSG:4326", crs, [lon], [lat])
    size = 100.0
    grid = dict(driver="GTiff", width=10, height=10, count=1, dtype="uint8", crs=crs,
                transform=Affine(size, 0.0, x - 5 * size, 0.0, -size, y + 5 * size))
    path = os.path.join(out, f"registry--{code}.tif")
    with rasterio.open(path, "w", **grid) as dst:
        dst.write(np.arange(100, dtype="uint8").reshape(1, 10, 10))
    drop_geokey(path, 3076)
    with rasterio.open(path) as src:
        per_unit = src.crs.linear_units_factor[1]
        assert src.crs.to_epsg() == code
    step = 10.0
    lons, lats = warp_transform(crs, "EPSG:4326", [x - step, x + step, x, x],
                                [y, y, y - step, y + step])
    along = [ground_metres((lons[i] + lons[i + 1]) / 2, (lats[i] + lats[i + 1]) / 2,
                           lons[i + 1] - lons[i], lats[i + 1] - lats[i]) / (2 * step)
             for i in (0, 2)]
    print(json.dumps({"name": f"registry--{code}", "source": "registry", "lossless": True,
                      "gdal": {"metres_per_unit": per_unit, "cell_units": size,
                               "south_west_units": [x - 5 * size, y - 5 * size],
                               "ground_metres_per_unit": along}}))


# GDAL's average over blocks of whole cells (rasterio's `reproject` to the transform
# scaled by the factor, the grid anchored at the north-west corner, the last blocks
# along the south and east edges clipped to the raster): what `imitate ingest --cells`
# must read a raster to. Float32 output, so that no mean is rounded to the source's
# integers; NaN where a block holds no data. The world image holds two values, which the
# reader takes for classes: GDAL's `mode` instead, as for a land-cover raster.
for source, file, factor, method in [
        ("spot", "osgeo_spot_chicago_utm.tif", 4, Resampling.average),
        ("spot", "osgeo_spot_chicago_utm.tif", 7, Resampling.average),
        ("world", "rasterio_world.byte.tif", 7, Resampling.mode)]:
    with rasterio.open(os.path.join(src_dir, file)) as src:
        data = src.read().astype("float32")
        profile = src.profile.copy()
        nodata = src.nodata
    if nodata is not None:
        data[data == nodata] = np.nan
    height, width = -(-data.shape[1] // factor), -(-data.shape[2] // factor)
    coarse = np.full((data.shape[0], height, width), np.nan, dtype="float32")
    transform = profile["transform"] * Affine.scale(factor)
    for band in range(data.shape[0]):
        reproject(data[band], coarse[band], src_transform=profile["transform"],
                  src_crs=profile["crs"], src_nodata=np.nan, dst_transform=transform,
                  dst_crs=profile["crs"], dst_nodata=np.nan, resampling=method)
    for key in ("compress", "predictor", "tiled", "blockxsize", "blockysize", "photometric",
                "interleave"):
        profile.pop(key, None)
    profile.update(driver="GTiff", dtype="float32", nodata=float("nan"), width=width,
                   height=height, transform=transform)
    name = f"coarse--{source}-by{factor}"
    with rasterio.open(os.path.join(out, name + ".tif"), "w", **profile) as dst:
        dst.write(coarse)
    print(json.dumps({"name": name, "source": "coarse", "lossless": True,
                      "raster": file, "factor": factor}))
