"""R raster grids (`.grd` header, `.gri` samples) as GDAL writes them (its RRASTER
driver, through rasterio) and as R's `raster` package writes them, each beside a
GeoTIFF twin of what GDAL reads it to. Prints one JSON line:

- `pairs` (GeoTIFF twin, grid): GDAL-written grids of every sample type it writes (a
  2-band float32 image in UTM with band names and nodata, by line; an int16 DEM in
  degrees, by band; uint8 by pixel; uint16, int32, uint32, float64), and a header as
  R's `raster` writes it (its sections and keys, big-endian INT2S samples, a PROJ
  string and no WKT, `nodatavalue` and `layername`), and that header with the PROJ
  strings of other projections (equal-area, oblique stereographic, Mercator, polar);
- `refused`: grids refused, by what is wrong: samples missing, a data type GDAL reads
  not (INT8S), a projection not read from a PROJ string (Robinson).
"""

import json
import os
import shutil
import sys

import numpy as np
import rasterio
from rasterio.transform import from_origin

from gdal_twin import twin, write_bands

out = sys.argv[1]
rng = np.random.default_rng(9)
field = rng.normal(size=(2, 60, 80)).cumsum(1).cumsum(2)


def path_of(name):
    return os.path.join(out, name)


def write(name, values, crs, transform, names=None, **options):
    return write_bands(path_of(name), "RRASTER", values, crs, transform, names, **options)


utm = from_origin(400020.0, 5200010.0, 10, 10)
degrees = from_origin(7.0, 47.0, 1 / 1200, 1 / 1200)
image = (field * 5 + 100).astype("float32")
image[:, 20:25, 30:40] = -9999
heights = (field[:1] * 3 + 1500).astype("int16")
grids = [
    write("image.grd", image, "EPSG:32632", utm, ("red", "nir"), nodata=-9999),
    write("dem.grd", heights, "EPSG:4326", degrees, INTERLEAVE="BSQ"),
    write("cover.grd", (np.abs(field[:1]) % 7).astype("uint8"), "EPSG:32632", utm,
          INTERLEAVE="BIP"),
    write("counts.grd", (np.abs(field) * 40).astype("uint16"), "EPSG:32632", utm),
    write("signed.grd", (field[:1] * 4e5).astype("int32"), "EPSG:32632", utm),
    write("large.grd", (np.abs(field[:1]) * 4e5).astype("uint32"), "EPSG:32632", utm),
    write("double.grd", field[1:] * 0.01 + 12.5, "EPSG:32632", utm),
]

# As R's raster package writes a grid: no WKT, big-endian samples written by R.
r_grid = path_of("r_dem.grd")
r_heights = heights[0].copy()
r_heights[5:9, 5:9] = -32768
r_heights.astype(">i2").tofile(path_of("r_dem.gri"))
with open(r_grid, "w") as f:
    f.write("[general]\ncreator=R package 'raster'\ncreated=2021-03-02 10:11:12\n"
            "[georeference]\nnrows=60\nncols=80\nxmin=7\nymin=46.95\nxmax=7.0666666666667\n"
            "ymax=47\nprojection=+proj=longlat +datum=WGS84 +no_defs\n[data]\n"
            "datatype=INT2S\nbyteorder=big\nnbands=1\nbandorder=BIL\ncategorical=FALSE\n"
            f"minvalue={r_heights.min()}\nmaxvalue={r_heights.max()}\nnodatavalue=-32768\n"
            "[legend]\nlegendtype=\nvalues=\ncolor=\n[description]\nlayername=elevation\n"
            "history=\n")


def variant(name, old, new, samples=True):
    """A copy of the R-written grid as `name`, its header's `old` made `new`."""
    target = path_of(name)
    open(target, "w").write(open(r_grid).read().replace(old, new))
    if samples:
        shutil.copy(path_of("r_dem.gri"), os.path.splitext(target)[0] + ".gri")
    return target


# Projections R writes as PROJ strings alone: equal-area, the Dutch grid (oblique
# stereographic on Bessel's ellipsoid), Mercator, a polar grid scaled at the pole.
projected = [
    variant("laea.grd", "+proj=longlat +datum=WGS84",
            "+proj=laea +lat_0=52 +lon_0=10 +x_0=4321000 +y_0=3210000 +ellps=GRS80 +units=m"),
    variant("sterea.grd", "+proj=longlat +datum=WGS84",
            "+proj=sterea +lat_0=52.1561605555556 +lon_0=5.38763888888889 +k=0.9999079 "
            "+x_0=155000 +y_0=463000 +ellps=bessel +units=m"),
    variant("merc.grd", "+proj=longlat +datum=WGS84", "+proj=merc +datum=WGS84"),
    variant("ups.grd", "+proj=longlat +datum=WGS84",
            "+proj=stere +lat_0=90 +lon_0=0 +k=0.994 +x_0=2000000 +y_0=2000000 +datum=WGS84"),
]
pairs = [twin(g) for g in grids + [r_grid] + projected]
refused = {
    "headless": variant("no_samples.grd", "", "", samples=False),
    "int8": variant("int8.grd", "datatype=INT2S", "datatype=INT8S"),
    "proj": variant("robin.grd", "+proj=longlat +datum=WGS84", "+proj=robin +datum=WGS84"),
}
print(json.dumps({"pairs": pairs, "refused": refused}))
