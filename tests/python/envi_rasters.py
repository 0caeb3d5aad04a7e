"""ENVI rasters as GDAL writes them (its ENVI driver, through rasterio) and as ENVI and
SNAP write them by hand, each beside a GeoTIFF twin of what GDAL reads it to (float32,
NaN where GDAL's mask says no data, the band names carried over): an int16 DEM in UTM
with nodata and a band name (`.img`, band-sequential), a float32 3-band image in
degrees interleaved by line, a uint16 4-band image interleaved by pixel (`.dat`), int32,
uint32, float64 and int64 bands; and by hand: big-endian samples after a header offset,
the header named `x.bsq.hdr`, the grid's reference pixel at the first cell's centre, a UTM
zone south named by `map info` alone (no coordinate system string). Also an ENVI header
whose data type is complex. Prints one JSON line: the pairs (GeoTIFF twin, ENVI raster)
and the complex one."""

import json
import os
import sys

import numpy as np
import rasterio
from rasterio.transform import from_origin

from gdal_twin import twin

out = sys.argv[1]
rng = np.random.default_rng(9)
field = rng.normal(size=(4, 70, 90)).cumsum(1).cumsum(2)


def path_of(name):
    return os.path.join(out, name)


def write(name, values, crs, transform, descriptions=None, **options):
    with rasterio.open(path_of(name), "w", driver="ENVI", width=values.shape[2],
                       height=values.shape[1], count=values.shape[0], dtype=values.dtype,
                       crs=crs, transform=transform, **options) as dst:
        dst.write(values)
        for band, text in enumerate(descriptions or [], start=1):
            dst.set_band_description(band, text)
    return path_of(name)


utm = from_origin(440000, 4640000, 30, 30)
dem = (field[0] * 3 + 200).astype("int16")
dem[20:30, 10:30] = -9999
files = [
    write("dem_utm.img", dem[None], "EPSG:32616", utm, ["elevation"], nodata=-9999),
    write("image_degrees.bil", (field[:3] * 0.25).astype("float32"), "EPSG:4326",
          from_origin(-100.0, 40.0, 1 / 1200, 1 / 1200), ["red", "green", "nir"],
          INTERLEAVE="BIL"),
    write("scene.dat", (field * 40 + 30000).clip(0, 65535).astype("uint16"), "EPSG:32616",
          utm, INTERLEAVE="BIP"),
    write("wide.img", np.stack([(field[0] * 1e5).astype("int32"),
                                np.abs(field[1] * 1e5).astype("int32")]), "EPSG:32616", utm),
    write("unsigned32.img", np.abs(field[:1] * 1e6).astype("uint32"), "EPSG:32616", utm),
    write("doubles.img", field[:2].astype("float64"), "EPSG:32616", utm, nodata=-1e30),
    write("int64.img", (field[:1] * 1e3).astype("int64"), "EPSG:32616", utm),
]

# By hand, as ENVI writes a scene: big-endian, a header offset, `x.bsq.hdr`, the
# reference pixel at the first cell's centre, a UTM zone south named by map info alone.
hand = path_of("scene_south.bsq")
values = (field[:2] * 10 + 1000).astype(">i2")
with open(hand, "wb") as f:
    f.write(b"\0" * 128)
    f.write(values.tobytes())
with open(hand + ".hdr", "w") as f:
    f.write("ENVI\ndescription = {\n  By hand, as ENVI writes it.}\nsamples = 90\n"
            "lines   = 70\nbands   = 2\nheader offset = 128\nfile type = ENVI Standard\n"
            "data type = 2\ninterleave = bsq\nsensor type = Unknown\nbyte order = 1\n"
            "map info = {UTM, 1.500, 1.500, 300015.000, 7200015.000, 3.0000000000e+01, "
            "3.0000000000e+01, 33, South, WGS-84, units=Meters}\n"
            "wavelength units = Nanometers\nband names = {\n Band A,\n Band B}\n")
files.append(hand)

complex_raster = path_of("complex.img")
np.zeros((10, 10), "complex64").tofile(complex_raster)
with open(path_of("complex.hdr"), "w") as f:
    f.write("ENVI\nsamples = 10\nlines = 10\nbands = 1\nheader offset = 0\n"
            "data type = 6\ninterleave = bsq\nbyte order = 0\n")

print(json.dumps({"pairs": [twin(p) for p in files], "complex": complex_raster}))
