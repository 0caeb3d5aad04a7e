"""Georeferenced PNG and JPEG images as GDAL writes them (through rasterio), each beside
a GeoTIFF twin of what GDAL reads it to (float32, NaN where GDAL's mask says no data,
the band descriptions, units, scales and offsets carried over): an RGB orthophoto PNG
(its CRS and grid in the .aux.xml sidecar), an RGBA one whose alpha clears a corner, a
16-bit DEM PNG in degrees with nodata (a transparent grey) and a scale, offset, unit
and description in the sidecar, a palette PNG of land-cover classes with one clear
entry, an RGB PNG whose transparent colour marks nodata, a 2-bit PNG georeferenced by a
hand-made world file (.pgw, no CRS), an RGB JPEG georeferenced by its world file alone,
and a grey JPEG with nodata (GDAL appends its mask to the file). Also a PNG with no
georeference at all. Prints one JSON line: the pairs (GeoTIFF twin, image), which are
lossy with how far libjpeg-turbo's decoding of each is from GDAL's, which hold classes, and the image with no georeference."""

import json
import os
import shutil
import sys
import warnings

import imagecodecs
import numpy as np
import rasterio
import rasterio.errors
from rasterio.transform import from_origin

from gdal_twin import twin

warnings.filterwarnings("ignore", category=rasterio.errors.NotGeoreferencedWarning)

out = sys.argv[1]
rng = np.random.default_rng(11)
utm = ("EPSG:32633", from_origin(500000, 4200000, 0.5, 0.5))


def write(name, values, crs, transform, driver, colormap=None, tags=None, **options):
    path = os.path.join(out, name)
    profile = dict(driver=driver, width=values.shape[2], height=values.shape[1],
                   count=values.shape[0], dtype=values.dtype, transform=transform, **options)
    if crs is not None:
        profile["crs"] = crs
    with rasterio.open(path, "w", **profile) as dst:
        dst.write(values)
        if colormap:
            dst.write_colormap(1, colormap)
        for key, value in (tags or {}).items():
            setattr(dst, key, value)
    return path


field = rng.normal(size=(3, 180, 240)).cumsum(1).cumsum(2)
image = (field - field.min()) / (field.max() - field.min())
rgb = (image * 255).astype("uint8")

ortho = write("ortho.png", rgb, *utm, "PNG")
rgba = np.concatenate([rgb, np.full((1, 180, 240), 255, "uint8")])
rgba[3, :40, :60] = 0
ortho_alpha = write("ortho_alpha.png", rgba, *utm, "PNG")
dem = (image[:1] * 3000 + 1).astype("uint16")
dem[0, 100:120, 30:70] = 0
dem16 = write("dem16.png", dem, "EPSG:4326", from_origin(7.0, 46.5, 1 / 1200, 1 / 1200),
              "PNG", nodata=0,
              tags={"descriptions": ("elevation",), "units": ("ft",), "scales": (0.5,),
                    "offsets": (10.0,)})
classes = write("classes.png", (image[:1] * 4.99).astype("uint8"), *utm, "PNG",
                colormap={0: (0, 0, 0, 0), 1: (20, 120, 20, 255), 2: (200, 200, 0, 255),
                          3: (0, 0, 200, 255), 4: (120, 120, 120, 255)})
rgb_clear = rgb.copy()
rgb_clear[:, 150:, 200:] = 5
rgb_nodata = write("rgb_nodata.png", rgb_clear, *utm, "PNG", nodata=5)

# A 2-bit PNG with a world file of its own (.pgw) and no sidecar.
two_bit = write("two_bit.png", (image[:1] * 3.99).astype("uint8"), None,
                from_origin(1000, 2000, 2, 2), "PNG", NBITS=2, WORLDFILE="YES")
os.replace(os.path.join(out, "two_bit.wld"), os.path.join(out, "two_bit.pgw"))
for leftover in ["two_bit.png.aux.xml"]:
    if os.path.exists(os.path.join(out, leftover)):
        os.remove(os.path.join(out, leftover))

# A JPEG photo georeferenced by its world file alone.
photo = write("photo.jpg", rgb, *utm, "JPEG", WORLDFILE="YES", QUALITY=90)
os.remove(photo + ".aux.xml")
grey = rgb[:1].copy()
grey[0, :30, :] = 3
grey_nodata = write("grey_nodata.jpg", grey, *utm, "JPEG", nodata=3)

pairs = [twin(p) for p in [ortho, ortho_alpha, dem16, classes, rgb_nodata, two_bit, photo,
                           grey_nodata]]


def peer_difference(path):
    """How far libjpeg-turbo's decoding (imagecodecs) is from GDAL's: its largest and
    mean difference, the yardstick for another decoder's."""
    turbo = imagecodecs.jpeg8_decode(open(path, "rb").read()).astype(float)
    if turbo.ndim == 2:
        turbo = turbo[:, :, None]
    with rasterio.open(path) as src:
        gdal = src.read().transpose(1, 2, 0).astype(float)
        valid = src.dataset_mask() > 0
    difference = np.abs(turbo - gdal)[valid]
    return [float(difference.max()), float(difference.mean())]


bare = os.path.join(out, "bare.png")
shutil.copy(ortho, bare)
lossy = {path: peer_difference(path) for path in [photo, grey_nodata]}
print(json.dumps({"pairs": pairs, "lossy": lossy, "classes": [classes], "bare": bare}))
