"""JPEG 2000 rasters as GDAL writes them (JP2OpenJPEG, through rasterio), each beside
the GeoTIFF of what GDAL reads it to: a Sentinel-2-like band (uint16 reflectances, UTM,
10 m, tiled with several resolutions and the RPCL progression ESA's files use), a
3-band image with its georeference only in the GMLJP2 box and one with it only in the
GeoJP2 box, a signed int16 DEM in degrees (GMLJP2's latitude-first axes), a band with
nodata, a name and a scale in GDAL's sidecar, an RGBA image whose opacity masks its
colours, and a lossy (9/7 wavelet) copy of the
3-band image. The twins are float32, NaN where GDAL masks a cell, with the bands' names
and scales. Also a bare codestream with no georeference.
Prints one JSON line: the pairs (GeoTIFF twin, JPEG 2000 file), which are lossy, and
the bare codestream."""

import json
import os
import sys
import warnings

import numpy as np
import rasterio
import rasterio.errors
from rasterio.transform import from_origin

warnings.filterwarnings("ignore", category=rasterio.errors.NotGeoreferencedWarning)

out = sys.argv[1]
rng = np.random.default_rng(5)


def write(name, values, crs, transform, tags=None, **options):
    path = os.path.join(out, name)
    with rasterio.open(path, "w", driver="JP2OpenJPEG", width=values.shape[2],
                       height=values.shape[1], count=values.shape[0], dtype=values.dtype,
                       crs=crs, transform=transform, **options) as dst:
        dst.write(values)
        for key, value in (tags or {}).items():
            setattr(dst, key, value)
    with rasterio.open(path) as src:
        read = src.read().astype("float32")
        read[src.read_masks() == 0] = np.nan
        twin = os.path.join(out, name + ".tif")
        with rasterio.open(twin, "w", driver="GTiff", width=src.width, height=src.height,
                           count=src.count, dtype="float32", crs=src.crs,
                           transform=src.transform, nodata=float("nan")) as dst:
            dst.write(read)
            dst.descriptions = src.descriptions
            dst.scales = src.scales
            dst.offsets = src.offsets
            dst.units = src.units
    return [twin, path]


lossless = {"QUALITY": 100, "REVERSIBLE": "YES"}
field = rng.normal(size=(3, 240, 320)).cumsum(1).cumsum(2)
image = (field * 4 + 3000).clip(0, 12000).astype("uint16")
utm = ("EPSG:32632", from_origin(399960, 5100000, 10, 10))
pairs = [
    write("T32TLR_B04.jp2", image[:1], *utm, BLOCKXSIZE=128, BLOCKYSIZE=128,
          RESOLUTIONS=4, PROGRESSION="RPCL", **lossless),
    write("gml_only.jp2", image, *utm, GeoJP2="NO", **lossless),
    write("geojp2_only.jp2", image, *utm, GMLJP2="NO", **lossless),
    write("dem_degrees.jp2", (field[:1] * 2 - 200).astype("int16"), "EPSG:4326",
          from_origin(7.0, 47.0, 0.001, 0.0005), GeoJP2="NO", **lossless),
]
# Nodata, a band name and a scale, which GDAL keeps in the .aux.xml sidecar.
band = image[:1].copy()
band[0, :20, :] = 0
pairs.append(write("B04_nodata.jp2", band, *utm, nodata=0,
                   tags={"descriptions": ("B04",), "scales": (0.0001,)}, **lossless))
# RGBA: the fourth component is opacity (a cdef box), which masks the others in GDAL.
rgba = np.concatenate([(image[:3] // 50).astype("uint8"), np.full((1, 240, 320), 255, "uint8")])
rgba[3, 100:140, :80] = 0
pairs.append(write("rgba.jp2", rgba, *utm, ALPHA="YES", **lossless))
lossy = write("lossy.jp2", image, *utm, QUALITY=20)
pairs.append(lossy)

bare = os.path.join(out, "bare.j2k")
with rasterio.open(bare, "w", driver="JP2OpenJPEG", width=64, height=64, count=1,
                   dtype="uint8", CODEC="J2K", **lossless) as dst:
    dst.write(image[:1, :64, :64].astype("uint8"))
print(json.dumps({"pairs": pairs, "lossy": [lossy[1]], "bare": bare}))
