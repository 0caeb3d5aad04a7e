"""PMTiles raster archives as Protomaps' own Python library writes them (`pmtiles`:
`mbtiles_to_pmtiles`, what `pmtiles convert` does) from MBTiles packages GDAL wrote, each
beside a GeoTIFF twin of what GDAL reads the MBTiles package to once its `bounds` are
the archive's (GDAL reads no raster PMTiles; an archive is read as its tiles are read in
MBTiles): PNG (GDAL's default), JPEG (which the converter marks as of unknown type),
palette PNG and lossless WebP tiles; a grey world at zoom level 1 whose three equal
tiles the writer stores once (a run of tiles); and both laid out again by the library's
own serializers with every entry in a leaf directory of its own. Also files to refuse:
vector tiles, a version 2 archive, a text file named .pmtiles. Prints one JSON line: the
pairs (twin, PMTiles), the lossy ones with how far libjpeg-turbo's decoding of the
MBTiles package's tiles is from GDAL's, and the refusals."""

import io
import json
import os
import shutil
import sqlite3
import sys

import imagecodecs
import numpy as np
from pmtiles.convert import mbtiles_to_pmtiles
from pmtiles.tile import (Compression, Entry, TileType, deserialize_directory,
                          deserialize_header, serialize_directory, serialize_header)

from gdal_twin import imagery_twin
from mbtiles_rasters import geotiff, imagery, mbtiles, peer_difference, tile_package


def archive(mbtiles_path):
    """`mbtiles_path` converted to PMTiles, and the twin of GDAL's reading of a copy of
    the package whose bounds are the archive's (degrees to 7 decimals)."""
    stem = os.path.splitext(mbtiles_path)[0]
    pmtiles_path = stem + ".pmtiles"
    mbtiles_to_pmtiles(mbtiles_path, pmtiles_path, None)
    with open(pmtiles_path, "rb") as f:
        header = deserialize_header(f.read(127))
    bounds = ",".join(repr(header[key] / 1e7) for key in
                      ("min_lon_e7", "min_lat_e7", "max_lon_e7", "max_lat_e7"))
    copy = stem + "_bounded.mbtiles"
    shutil.copy(mbtiles_path, copy)
    db = sqlite3.connect(copy)
    db.execute("DELETE FROM metadata WHERE name = 'bounds'")
    db.execute("INSERT INTO metadata VALUES ('bounds', ?)", (bounds,))
    db.commit()
    db.close()
    return pmtiles_path, copy


def in_leaves(pmtiles_path):
    """A copy of the archive laid out again with every tile entry in a leaf directory of
    its own, the root pointing at the leaves (the layout of archives too large for one
    directory)."""
    with open(pmtiles_path, "rb") as f:
        data = f.read()
    header = deserialize_header(data[:127])
    root = deserialize_directory(data[header["root_offset"]:
                                      header["root_offset"] + header["root_length"]])
    metadata = data[header["metadata_offset"]:
                    header["metadata_offset"] + header["metadata_length"]]
    tiles = data[header["tile_data_offset"]:
                 header["tile_data_offset"] + header["tile_data_length"]]
    leaves, pointers = io.BytesIO(), []
    for entry in root:
        leaf = serialize_directory([entry])
        pointers.append(Entry(entry.tile_id, leaves.tell(), len(leaf), 0))
        leaves.write(leaf)
    root_bytes = serialize_directory(pointers)
    header["root_offset"] = 127
    header["root_length"] = len(root_bytes)
    header["metadata_offset"] = 127 + len(root_bytes)
    header["leaf_directory_offset"] = header["metadata_offset"] + len(metadata)
    header["leaf_directory_length"] = leaves.tell()
    header["tile_data_offset"] = header["leaf_directory_offset"] + leaves.tell()
    path = os.path.splitext(pmtiles_path)[0] + "_leaves.pmtiles"
    with open(path, "wb") as f:
        f.write(serialize_header(header) + root_bytes + metadata + leaves.getvalue() + tiles)
    return path


def grey_world(out):
    """An MBTiles package of the whole world at zoom level 1 (and 0) in grey 64-cell PNG
    tiles: three of the four the same, which the PMTiles writer stores as runs."""
    plain = imagecodecs.png_encode(np.full((64, 64), 90, "uint8"))
    ramp = imagecodecs.png_encode(np.tile(np.arange(64, dtype="uint8") * 4, (64, 1)))
    return tile_package(
        os.path.join(out, "world.mbtiles"),
        [("name", "world"), ("format", "png"), ("minzoom", "0"), ("maxzoom", "1"),
         ("bounds", "-180,-85.0511287798066,180,85.0511287798066")],
        [(0, 0, 0, plain), (1, 0, 0, plain), (1, 0, 1, plain), (1, 1, 1, plain),
         (1, 1, 0, ramp)])


def refused(out):
    """A vector archive, a version 2 archive and a text file, each named .pmtiles."""
    vector = os.path.join(out, "roads.pmtiles")
    root = serialize_directory([Entry(0, 0, 2, 1)])
    header = {"root_offset": 127, "root_length": len(root), "metadata_offset": 127 + len(root),
              "metadata_length": 0, "tile_data_offset": 127 + len(root),
              "tile_data_length": 2, "clustered": True,
              "internal_compression": Compression.GZIP, "tile_compression": Compression.GZIP,
              "tile_type": TileType.MVT, "min_zoom": 0, "max_zoom": 0}
    with open(vector, "wb") as f:
        f.write(serialize_header(header) + root + b"\x1f\x8b")
    old = os.path.join(out, "old.pmtiles")
    with open(old, "wb") as f:
        f.write(b"PM\x02\x00" + bytes(200))
    text = os.path.join(out, "text.pmtiles")
    with open(text, "w") as f:
        f.write("not an archive\n")
    return {"vector": vector, "old": old, "text": text}


def main():
    out = sys.argv[1]
    rgb_tif = geotiff(out, "rgb", imagery())
    pairs, lossy = [], {}
    for name, options, bands in [("png", {}, 3), ("jpeg", {"TILE_FORMAT": "JPEG"}, 3),
                                 ("png8", {"TILE_FORMAT": "PNG8"}, 3),
                                 ("webp", {"TILE_FORMAT": "WEBP", "WEBP_LOSSLESS": "YES"}, 3),
                                 ("world", None, 1)]:
        source = (grey_world(out) if options is None
                  else mbtiles(out, "rgb_" + name, rgb_tif, **options))
        pmtiles_path, bounded = archive(source)
        twin = imagery_twin(bounded, bands)[0]
        pairs.append([twin, pmtiles_path])
        if name in ("png", "world"):
            pairs.append([twin, in_leaves(pmtiles_path)])
        if name == "jpeg":
            lossy[pmtiles_path] = peer_difference(bounded)
    print(json.dumps({"pairs": pairs, "lossy": lossy, "refused": refused(out)}))


if __name__ == "__main__":
    main()
