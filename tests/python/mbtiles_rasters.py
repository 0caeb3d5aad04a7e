"""MBTiles rasters as GDAL writes them (its MBTiles driver, through rasterio; the source,
in UTM, is warped to Web Mercator on the way) and as tile tools lay them out, each beside
a GeoTIFF twin of what GDAL reads it to: imagery in PNG tiles (GDAL's default), JPEG,
8-bit palette PNG and (lossy) WebP tiles; grey; overviews, which leave the full
resolution the highest zoom level; no `bounds` in the metadata (the extent is then the
tiles'); `bounds` rounded to four decimals by hand, which no longer fall on a cell edge
(GDAL shifts the tiles' cells to the nearest); and a deduplicated file whose `tiles` is a
view over `map` and `images` (mbutil's and MapTiler's layout), written here from the tiles
of another. GDAL shows MBTiles as RGBA: the twin keeps the colour bands (one where the
source was grey) and NaN where GDAL's mask is 0. Also files to refuse: vector tiles
(format pbf), a GeoPackage named .mbtiles, a text file named .mbtiles. Prints one JSON
line: the pairs (twin, MBTiles), the lossy ones with how far libjpeg-turbo's or
libwebp's decoding of their tiles is from GDAL's, and the refusals."""

import json
import math
import os
import shutil
import sqlite3
import sys

import numpy as np
import rasterio
import rasterio.shutil
from rasterio.enums import Resampling
from rasterio.transform import from_origin

from gdal_twin import imagery_twin, lossy_tiles_difference

HALF_WORLD = 6378137.0 * math.pi


def imagery():
    """A seeded 3 × 240 × 320 image of smooth random colours, 1 to 255."""
    field = np.random.default_rng(11).normal(size=(3, 240, 320)).cumsum(1).cumsum(2)
    image = (field - field.min()) / (field.max() - field.min())
    return (image * 254 + 1).astype("uint8")


def geotiff(out, name, values):
    path = os.path.join(out, name + ".tif")
    with rasterio.open(path, "w", driver="GTiff", width=values.shape[2],
                       height=values.shape[1], count=values.shape[0], dtype=values.dtype,
                       crs="EPSG:32633", transform=from_origin(500000, 5200000, 10, 10)) as dst:
        dst.write(values)
    return path


def mbtiles(out, name, source, **options):
    path = os.path.join(out, name + ".mbtiles")
    rasterio.shutil.copy(source, path, driver="MBTiles", **options)
    return path


def peer_difference(path):
    """`lossy_tiles_difference` of the package's full resolution, its tiles placed as
    GDAL places them: rows from the south, shifted to the nearest cell of the grid."""
    with rasterio.open(path) as src:
        cell = src.transform.a
        shift_x = math.floor((src.transform.c + HALF_WORLD) / cell + 0.5)
        shift_y = math.floor((HALF_WORLD - src.transform.f) / cell + 0.5)
        side = src.block_shapes[0][0]
    db = sqlite3.connect(path)
    (zoom,) = db.execute("SELECT MAX(zoom_level) FROM tiles").fetchone()
    rows = db.execute("SELECT tile_column, tile_row, tile_data FROM tiles "
                      "WHERE zoom_level = ?", (zoom,)).fetchall()
    db.close()
    placed = [(((1 << zoom) - 1 - row) * side - shift_y, column * side - shift_x, data)
              for column, row, data in rows]
    return lossy_tiles_difference(path, placed)


def tile_package(path, metadata, tiles):
    """An MBTiles package written by hand: `metadata` (name, value) pairs and `tiles`
    (zoom level, column, row from the south, bytes)."""
    db = sqlite3.connect(path)
    db.executescript("""
        CREATE TABLE metadata (name TEXT, value TEXT);
        CREATE TABLE tiles (zoom_level INTEGER, tile_column INTEGER, tile_row INTEGER,
                            tile_data BLOB);
    """)
    db.executemany("INSERT INTO metadata VALUES (?, ?)", metadata)
    db.executemany("INSERT INTO tiles VALUES (?, ?, ?, ?)", tiles)
    db.commit()
    db.close()
    return path


def without_bounds(out, name, source):
    """A copy of `source` whose metadata gives no bounds."""
    path = os.path.join(out, name + ".mbtiles")
    shutil.copy(source, path)
    db = sqlite3.connect(path)
    db.execute("DELETE FROM metadata WHERE name = 'bounds'")
    db.commit()
    db.close()
    return path


def rounded_bounds(out, name, source):
    """A copy of `source` whose bounds are rounded to four decimals, as a hand or a
    tool that writes them for display leaves them."""
    path = os.path.join(out, name + ".mbtiles")
    shutil.copy(source, path)
    db = sqlite3.connect(path)
    (bounds,) = db.execute("SELECT value FROM metadata WHERE name = 'bounds'").fetchone()
    west, south, east, north = (float(v) for v in bounds.split(","))
    rounded = f"{west:.4f},{south:.4f},{east:.4f},{north:.4f}"
    db.execute("UPDATE metadata SET value = ? WHERE name = 'bounds'", (rounded,))
    db.commit()
    db.close()
    return path


def deduplicated(out, name, source):
    """`source`'s tiles laid out as mbutil and MapTiler write them: each distinct image
    once in `images`, `map` placing it, `tiles` a view joining the two."""
    path = os.path.join(out, name + ".mbtiles")
    src = sqlite3.connect(source)
    db = sqlite3.connect(path)
    db.executescript("""
        CREATE TABLE metadata (name TEXT, value TEXT);
        CREATE TABLE map (zoom_level INTEGER, tile_column INTEGER, tile_row INTEGER,
                          tile_id TEXT);
        CREATE TABLE images (tile_data BLOB, tile_id TEXT);
        CREATE VIEW tiles AS SELECT map.zoom_level AS zoom_level,
            map.tile_column AS tile_column, map.tile_row AS tile_row,
            images.tile_data AS tile_data
            FROM map JOIN images ON images.tile_id = map.tile_id;
    """)
    db.executemany("INSERT INTO metadata VALUES (?, ?)",
                   src.execute("SELECT name, value FROM metadata"))
    ids = {}
    for zoom, column, row, data in src.execute(
            "SELECT zoom_level, tile_column, tile_row, tile_data FROM tiles"):
        if bytes(data) not in ids:
            ids[bytes(data)] = str(len(ids))
            db.execute("INSERT INTO images VALUES (?, ?)", (data, ids[bytes(data)]))
        key = ids[bytes(data)]
        db.execute("INSERT INTO map VALUES (?, ?, ?, ?)", (zoom, column, row, key))
    db.commit()
    db.close()
    src.close()
    return path


def main():
    out = sys.argv[1]
    rgb = imagery()
    pairs, lossy = [], []
    rgb_tif = geotiff(out, "rgb", rgb)
    png = mbtiles(out, "rgb_png", rgb_tif)
    pairs.append(imagery_twin(png, 3))
    jpeg = mbtiles(out, "rgb_jpeg", rgb_tif, TILE_FORMAT="JPEG")
    pairs.append(imagery_twin(jpeg, 3))
    lossy.append(jpeg)
    pairs.append(imagery_twin(mbtiles(out, "rgb_png8", rgb_tif, TILE_FORMAT="PNG8"), 3))
    webp = mbtiles(out, "rgb_webp", rgb_tif, TILE_FORMAT="WEBP")
    pairs.append(imagery_twin(webp, 3))
    lossy.append(webp)
    grey = mbtiles(out, "grey", geotiff(out, "grey", rgb[:1]))
    pairs.append(imagery_twin(grey, 1))
    overviews = mbtiles(out, "overviews", rgb_tif)
    with rasterio.open(overviews, "r+") as dst:
        dst.build_overviews([2, 4], Resampling.average)
    pairs.append(imagery_twin(overviews, 3))
    pairs.append(imagery_twin(without_bounds(out, "no_bounds", png), 3))
    pairs.append(imagery_twin(rounded_bounds(out, "rounded_bounds", png), 3))
    pairs.append(imagery_twin(deduplicated(out, "deduplicated", png), 3))

    # Refusals.
    vector = tile_package(os.path.join(out, "roads.mbtiles"),
                          [("format", "pbf"), ("minzoom", "0"), ("maxzoom", "0")],
                          [(0, 0, 0, b"\x1f\x8b")])
    geopackage = os.path.join(out, "geopackage.mbtiles")
    rasterio.shutil.copy(rgb_tif, geopackage, driver="GPKG")
    text = os.path.join(out, "text.mbtiles")
    with open(text, "w") as f:
        f.write("not a database\n")
    print(json.dumps({"pairs": pairs, "lossy": {path: peer_difference(path) for path in lossy},
                      "refused": {"vector": vector, "geopackage": geopackage, "text": text}}))


if __name__ == "__main__":
    main()
