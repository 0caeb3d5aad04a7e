"""GeoPackage rasters as GDAL writes them (its GPKG driver, through rasterio), each beside
a GeoTIFF twin of what GDAL reads it to: imagery tiles (GDAL's default mix of JPEG and
PNG, PNG alone, grey JPEG, 8-bit palette PNG, WebP (lossy: GDAL's GPKG driver writes no
lossless WebP); RGB, grey with a nodata value; grey and RGB with a tile of zeros, which
GDAL leaves out; cells not square; overviews, which leave
the full resolution the highest zoom level; a Web Mercator tile grid the raster sits
inside at an offset) and gridded coverages (int16, uint16 and float32 DEMs with nodata
in 16-bit PNG tiles, float32 in TIFF tiles; one in feet, one in degrees). GDAL shows imagery as the
bands it recorded (else RGBA): the twin keeps the colour bands (one where the source
was grey) and NaN where GDAL's mask is 0. Also files to refuse: two rasters in one
GeoPackage, one holding only features, and a text file named .gpkg. Prints one JSON
line: the pairs (twin, GeoPackage), which are lossy with how far libjpeg-turbo's or
libwebp's decoding of their tiles is from GDAL's, and the refusals."""

import json
import os
import sqlite3
import sys

import numpy as np
import rasterio
import rasterio.shutil
from rasterio.enums import Resampling
from rasterio.transform import from_origin

from gdal_twin import imagery_twin, lossy_tiles_difference, twin

out = sys.argv[1]
rng = np.random.default_rng(5)
utm = "EPSG:32633"
field = rng.normal(size=(3, 300, 417)).cumsum(1).cumsum(2)
image = (field - field.min()) / (field.max() - field.min())
rgb = (image * 254 + 1).astype("uint8")


def geotiff(name, values, crs=utm, transform=from_origin(500000, 4200000, 30, 30),
            nodata=None):
    path = os.path.join(out, name + ".tif")
    with rasterio.open(path, "w", driver="GTiff", width=values.shape[2],
                       height=values.shape[1], count=values.shape[0], dtype=values.dtype,
                       crs=crs, transform=transform, nodata=nodata) as dst:
        dst.write(values)
    return path


def gpkg(name, source, **options):
    path = os.path.join(out, name + ".gpkg")
    rasterio.shutil.copy(source, path, driver="GPKG", **options)
    return path


def peer_difference(path):
    """`lossy_tiles_difference` of the GeoPackage's full resolution, its tiles placed
    from the tile matrix's north-west corner (where GDAL's raster starts here)."""
    db = sqlite3.connect(path)
    (table,) = db.execute("SELECT table_name FROM gpkg_contents").fetchone()
    (zoom,) = db.execute(f'SELECT MAX(zoom_level) FROM "{table}"').fetchone()
    tw, th = db.execute("SELECT tile_width, tile_height FROM gpkg_tile_matrix WHERE "
                        "table_name = ? AND zoom_level = ?", (table, zoom)).fetchone()
    placed = [(row * th, column * tw, data) for column, row, data in db.execute(
        f'SELECT tile_column, tile_row, tile_data FROM "{table}" WHERE zoom_level = ?',
        (zoom,))]
    db.close()
    return lossy_tiles_difference(path, placed)


pairs, lossy = [], []
rgb_tif = geotiff("rgb", rgb)
auto = gpkg("rgb_auto", rgb_tif)
pairs.append(imagery_twin(auto, 3))
lossy.append(auto)
pairs.append(imagery_twin(gpkg("rgb_png", rgb_tif, TILE_FORMAT="PNG"), 3))
pairs.append(imagery_twin(gpkg("rgb_png8", rgb_tif, TILE_FORMAT="PNG8"), 3))
webp = gpkg("rgb_webp", rgb_tif, TILE_FORMAT="WEBP")
pairs.append(imagery_twin(webp, 3))
lossy.append(webp)
grey = rgb[:1].copy()
grey[0, 260:, 360:] = 0
grey_tif = geotiff("grey", grey, nodata=0)
pairs.append(imagery_twin(gpkg("grey_png", grey_tif, TILE_FORMAT="PNG"), 1))
# GDAL's default keeps grey rasters in PNG tiles; asked, it writes grey JPEGs.
grey_jpeg = gpkg("grey_jpeg", geotiff("grey_plain", rgb[:1]), TILE_FORMAT="JPEG")
pairs.append(imagery_twin(grey_jpeg, 1))
lossy.append(grey_jpeg)
oblong = geotiff("oblong", rgb, transform=from_origin(500000, 4200000, 30, 20))
pairs.append(imagery_twin(gpkg("oblong", oblong, TILE_FORMAT="PNG"), 3))

# Tiles of zeros alone: GDAL leaves them out, and reads them back as zeros where the
# raster has no alpha band.
sparse = rgb.copy()
sparse[:, :260, :260] = 0
pairs.append(imagery_twin(gpkg("sparse_grey", geotiff("sparse_grey", sparse[:1]),
                               TILE_FORMAT="PNG"), 1))
pairs.append(imagery_twin(gpkg("sparse_rgb", geotiff("sparse_rgb", sparse),
                               TILE_FORMAT="PNG"), 3))

# Overviews: GDAL adds zoom levels below the full resolution.
with_overviews = gpkg("overviews", rgb_tif, TILE_FORMAT="PNG")
with rasterio.open(with_overviews, "r+") as dst:
    dst.build_overviews([2, 4], Resampling.average)
pairs.append(imagery_twin(with_overviews, 3))

# A Web Mercator tile grid: the raster starts inside a tile, the grid's origin far off.
mercator = geotiff("mercator", rgb[:, :90, :120], crs="EPSG:3857",
                   transform=from_origin(1_113_194.9, 6_446_275.8, 19.109, 19.109))
pairs.append(imagery_twin(gpkg("mercator", mercator, TILE_FORMAT="PNG",
                               TILING_SCHEME="GoogleMapsCompatible"), 3))

dem = (image[0] * 2800 - 50).astype("float32")
dem[100:120, 30:70] = -9999
for name, dtype, options in [("dem_int16", "int16", {}), ("dem_uint16", "uint16", {}),
                             ("dem_float_png", "float32", {"TILE_FORMAT": "PNG"}),
                             ("dem_float_tiff", "float32", {"TILE_FORMAT": "TIFF"})]:
    values = dem.copy()
    nodata = -9999
    if dtype == "uint16":
        values[values < 0] = 0
        values[100:120, 30:70] = 0
        nodata = 0
    source = geotiff(name, values[None].astype(dtype), nodata=nodata)
    path = gpkg(name, source, **options)
    pairs.append(twin(path))
# Heights in feet: GDAL writes the band's unit as the coverage's unit of measure.
feet = geotiff("dem_feet", dem[None].astype("int16"), nodata=-9999)
with rasterio.open(feet, "r+") as dst:
    dst.units = ("ft",)
pairs.append(twin(gpkg("dem_feet", feet)))
degrees = geotiff("dem_degrees", dem[None].astype("int16"), crs="EPSG:4326",
                  transform=from_origin(7.0, 46.5, 1 / 1200, 1 / 1200), nodata=-9999)
pairs.append(twin(gpkg("dem_degrees", degrees)))

# Refusals.
two = gpkg("two_rasters", rgb_tif, RASTER_TABLE="first", TILE_FORMAT="PNG")
rasterio.shutil.copy(grey_tif, two, driver="GPKG", RASTER_TABLE="second",
                     APPEND_SUBDATASET="YES", TILE_FORMAT="PNG")
features = os.path.join(out, "features.gpkg")
db = sqlite3.connect(features)
db.executescript("""
    CREATE TABLE gpkg_contents (table_name TEXT PRIMARY KEY, data_type TEXT, identifier TEXT,
        description TEXT, last_change TEXT, min_x REAL, min_y REAL, max_x REAL, max_y REAL,
        srs_id INTEGER);
    INSERT INTO gpkg_contents VALUES ('roads', 'features', 'roads', '', '', 0, 0, 1, 1, 4326);
""")
db.close()
text = os.path.join(out, "text.gpkg")
with open(text, "w") as f:
    f.write("not a database\n")
print(json.dumps({"pairs": pairs, "lossy": {path: peer_difference(path) for path in lossy},
                  "refused": {"two": two, "features": features, "text": text}}))
