"""ERDAS Imagine rasters (`.img`) as GDAL writes them (its HFA driver, through rasterio),
each beside a GeoTIFF twin of what GDAL reads it to (float32, NaN where GDAL's mask says
no data, the band names carried over): an int16 DEM in UTM with nodata and a band name
(raw blocks), a float32 3-band image in degrees (run-length compressed), a thematic
uint8 land cover with a colour table (compressed, edge blocks), uint16 with nodata in
blocks of 32, 4-bit and 1-bit samples, int8, int32 and uint32 (compressed), float64, and
a UTM DEM written without a PE string (ERDAS's projection parameters alone), two layers
whose blocks lie in a spill file (`.ige`); the DEM has an ENVI raster of its own name
beside it (`dem_utm.dat`, its header `dem_utm.hdr`). Also raw
samples named `.img` with no header at all (`headerless.img`). Prints one JSON line: the
pairs (GeoTIFF twin, Imagine file) and the thematic files."""

import json
import os
import sys

import numpy as np
import rasterio
from rasterio.transform import from_origin

from gdal_twin import twin

out = sys.argv[1]
rng = np.random.default_rng(5)
field = rng.normal(size=(3, 150, 201)).cumsum(1).cumsum(2)


def path_of(name):
    return os.path.join(out, name)


def write(name, values, crs, transform, descriptions=None, colormap=None, **options):
    with rasterio.open(path_of(name), "w", driver="HFA", width=values.shape[2],
                       height=values.shape[1], count=values.shape[0], dtype=values.dtype,
                       crs=crs, transform=transform, **options) as dst:
        dst.write(values)
        for band, text in enumerate(descriptions or [], start=1):
            dst.set_band_description(band, text)
        if colormap:
            dst.write_colormap(1, colormap)
    return path_of(name)


utm = from_origin(440000, 4640000, 30, 30)
dem = (field[0] * 3 + 200).astype("int16")
dem[40:50, 10:30] = -32768
files = [
    write("dem_utm.img", dem[None], "EPSG:32616", utm, ["elevation"], nodata=-32768),
    write("image_degrees.img", (field * 0.25).astype("float32"), "EPSG:4326",
          from_origin(-100.0, 40.0, 1 / 1200, 1 / 1200), COMPRESSED="YES"),
]
cover = (np.abs(field[1]) // 7 % 9).astype("uint8")
cover[:, :30] = 11
colours = {i: (i * 20, 255 - i * 20, (i * 50) % 256, 255) for i in range(12)}
thematic = write("land_cover.img", cover[None], "EPSG:32616", utm, colormap=colours,
                 COMPRESSED="YES")
files.append(thematic)
counts = (field[2] * 40 + 30000).clip(0, 65535).astype("uint16")
counts[100:, 150:] = 0
files.append(write("counts_blocks32.img", counts[None], "EPSG:32616", utm, nodata=0,
                   BLOCKSIZE=32, COMPRESSED="YES"))
nibbles = (np.abs(field[0]) % 16).astype("uint8")
files.append(write("nibbles.img", nibbles[None], "EPSG:32616", utm, NBITS=4))
files.append(write("nibbles_compressed.img", nibbles[None], "EPSG:32616", utm, NBITS=4,
                   COMPRESSED="YES"))
bits = (field[1] > 0).astype("uint8")
files.append(write("mask_bits.img", bits[None], "EPSG:32616", utm, NBITS=1))
files.append(write("signed_bytes.img", (field[:1] % 200 - 100).astype("int8"),
                   "EPSG:32616", utm, COMPRESSED="YES"))
files.append(write("wide.img", np.stack([(field[0] * 1e5).astype("int32"),
                                         np.abs(field[1] * 1e5).astype("int32")]),
                   "EPSG:32616", utm, COMPRESSED="YES"))
files.append(write("unsigned32.img", np.abs(field[:1] * 1e6).astype("uint32"),
                   "EPSG:32616", utm, COMPRESSED="YES"))
files.append(write("doubles.img", field[:2].astype("float64"), "EPSG:32616", utm,
                   nodata=-1e30))
files.append(write("dem_parameters.img", dem[None], "EPSG:26915", utm, nodata=-32768,
                   DISABLEPESTRING="YES"))
# Blocks in a spill file (x.ige), as GDAL writes past 2 GiB and NLCD comes: two layers
# stacked block by block.
files.append(write("spilled.img", np.stack([dem, (field[1] * 9).astype("int16")]),
                   "EPSG:32616", utm, nodata=-32768, USE_SPILL="YES"))

# An ENVI raster of the same name beside an Imagine file (its header dem_utm.hdr): the
# .img is still Imagine, as GDAL tells them apart by the file's own tag.
with rasterio.open(path_of("dem_utm.dat"), "w", driver="ENVI", width=50, height=40, count=1,
                   dtype="uint8", crs="EPSG:32616", transform=utm) as dst:
    dst.write(np.ones((1, 40, 50), "uint8"))

# Raw samples named .img with no header of any kind: neither Imagine nor ENVI.
np.zeros((40, 50), "uint8").tofile(path_of("headerless.img"))

print(json.dumps({"pairs": [twin(p) for p in files], "thematic": [thematic]}))
