"""Raw rasters with an ESRI header as GDAL writes them (its EHdr driver, through
rasterio) and as the USGS hands them out, each beside a GeoTIFF twin of what GDAL reads
it to (float32, NaN where GDAL's mask says no data, the band names carried over): an
SRTM-like int16 DEM in degrees with nodata (`.bil`, as EarthExplorer's SRTM tiles), a
float32 DEM in UTM (`.flt`), a 3-band uint16 image (`.bil`), its samples laid out again
by pixel (`.bip`) and by band (`.bsq`) with a big-endian copy, and a GridFloat DEM with
the USGS's lowercase header (`xllcorner`, `cellsize`, `byteorder MSBFIRST`) and its
`.prj`. Also a `.bil` whose header is missing. Prints one JSON line: the pairs (GeoTIFF
twin, raw raster) and the one without a header."""

import json
import os
import shutil
import sys
import warnings

import numpy as np
import rasterio
import rasterio.errors
from rasterio.transform import from_origin

from gdal_twin import twin

warnings.filterwarnings("ignore", category=rasterio.errors.NotGeoreferencedWarning)

out = sys.argv[1]
rng = np.random.default_rng(3)
field = rng.normal(size=(3, 90, 120)).cumsum(1).cumsum(2)


def path_of(name):
    return os.path.join(out, name)


def write(name, values, crs, transform, **options):
    with rasterio.open(path_of(name), "w", driver="EHdr", width=values.shape[2],
                       height=values.shape[1], count=values.shape[0], dtype=values.dtype,
                       crs=crs, transform=transform, **options) as dst:
        dst.write(values)
    return path_of(name)


def relaid(source, name, layout, big_endian=False):
    """`source` (a BIL of 16-bit samples) laid out again by `layout`, in either order."""
    with rasterio.open(source) as src:
        values = src.read()
    dtype = values.dtype.newbyteorder(">" if big_endian else "<")
    if layout == "BIP":
        raw = values.transpose(1, 2, 0).astype(dtype).tobytes()
    else:
        raw = values.astype(dtype).tobytes()
    base = os.path.splitext(source)[0]
    target = path_of(name)
    with open(target, "wb") as f:
        f.write(raw)
    header = open(base + ".hdr").read().splitlines()
    keep = [line for line in header
            if line.split()[0] not in ("LAYOUT", "BANDROWBYTES", "TOTALROWBYTES", "BYTEORDER")]
    keep += ["LAYOUT         " + layout, "BYTEORDER      " + ("M" if big_endian else "I")]
    open(os.path.splitext(target)[0] + ".hdr", "w").write("\n".join(keep) + "\n")
    shutil.copy(base + ".prj", os.path.splitext(target)[0] + ".prj")
    return target


dem = (field[0] * 3 + 1500).astype("int16")
dem[40:50, 10:30] = -32768
srtm = write("n46_e007_3arc_v2.bil", dem[None], "EPSG:4326",
             from_origin(7.0, 47.0, 1 / 1200, 1 / 1200), nodata=-32768)
utm_dem = write("dem_utm.flt", (field[:1] * 0.7 + 300).astype("float32"), "EPSG:32632",
                from_origin(400000, 5200000, 10, 10), nodata=-9999)
image = (field * 10 + 20000).clip(0, 65535).astype("uint16")
bands = write("image.bil", image, "EPSG:32632", from_origin(400000, 5200000, 10, 10))
by_pixel = relaid(bands, "image_pixels.bip", "BIP")
by_band = relaid(bands, "image_bands.bsq", "BSQ", big_endian=True)

# The USGS's GridFloat: lowercase keys, the lower-left corner, big-endian floats.
usgs = path_of("usgs_ned.flt")
values = (field[1] * 0.5 + 800).astype(">f4")
values[:5, :5] = -9999
values.tofile(usgs)
with open(path_of("usgs_ned.hdr"), "w") as f:
    f.write("ncols         120\nnrows         90\nxllcorner     -105.5\n"
            "yllcorner     39.25\ncellsize      0.000277777777778\n"
            "NODATA_value  -9999\nbyteorder     MSBFIRST\n")
shutil.copy(os.path.splitext(srtm)[0] + ".prj", path_of("usgs_ned.prj"))

pairs = [twin(p) for p in [srtm, utm_dem, bands, by_pixel, by_band, usgs]]

headless = path_of("headless.bil")
shutil.copy(bands, headless)
print(json.dumps({"pairs": pairs, "headless": headless}))
