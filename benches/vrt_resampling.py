#!/usr/bin/env python3
"""GDAL virtual rasters that resample their source, read by imitate and by GDAL.

Writes a 4000² float32 DEM-like GeoTIFF with a void (tiled, nodata −9999) and five VRTs
over it with rasterio: the same size (nearest), shrunk to 1600² by `average` and
`cubic`, grown to 8000² by `bilinear` and `cubic`. For each VRT, three times in turn:
the wall time of `imitate inspect VRT` (a new process: it reads the VRT whole and
summarises its layer) and of GDAL's reading of it through rasterio (`read(1,
masked=True)`, in this process). Prints one line per VRT: the median of each and
their ratio.

    PYTHONPATH=target/python-deps python3 benches/vrt_resampling.py target/release/imitate DIR
"""

import os
import statistics
import subprocess
import sys
import time

import numpy as np
import rasterio
from rasterio.transform import from_origin

imitate, out = sys.argv[1], sys.argv[2]
os.makedirs(out, exist_ok=True)
rng = np.random.default_rng(0)
dem = (800 + rng.normal(size=(4000, 4000)).cumsum(0) * 0.5).astype("float32")
dem[1000:1100, 2000:2300] = -9999
source = os.path.join(out, "source.tif")
with rasterio.open(source, "w", driver="GTiff", width=4000, height=4000, count=1,
                   dtype="float32", crs="EPSG:32633", tiled=True, nodata=-9999,
                   transform=from_origin(500000, 5000000, 10, 10)) as dst:
    dst.write(dem, 1)


def vrt(name, size, resampling):
    path = os.path.join(out, name + ".vrt")
    with open(path, "w") as f:
        f.write(f"""<VRTDataset rasterXSize="{size}" rasterYSize="{size}">
  <SRS>EPSG:32633</SRS>
  <GeoTransform>500000, {40000 / size}, 0, 5000000, 0, {-40000 / size}</GeoTransform>
  <VRTRasterBand dataType="Float32" band="1">
    <NoDataValue>-9999</NoDataValue>
    <ComplexSource resampling="{resampling}">
      <SourceFilename relativeToVRT="1">source.tif</SourceFilename>
      <SourceBand>1</SourceBand>
      <SrcRect xOff="0" yOff="0" xSize="4000" ySize="4000" />
      <DstRect xOff="0" yOff="0" xSize="{size}" ySize="{size}" />
      <NODATA>-9999</NODATA>
    </ComplexSource>
  </VRTRasterBand>
</VRTDataset>""")
    return path


for name, size, resampling in [("nearest", 4000, "nearest"), ("shrunk-average", 1600, "average"),
                               ("shrunk-cubic", 1600, "cubic"),
                               ("grown-bilinear", 8000, "bilinear"),
                               ("grown-cubic", 8000, "cubic")]:
    path = vrt(name, size, resampling)
    ours, gdal = [], []
    for _ in range(3):
        started = time.perf_counter()
        subprocess.run([imitate, "inspect", path], check=True, stdout=subprocess.DEVNULL)
        ours.append(time.perf_counter() - started)
        started = time.perf_counter()
        with rasterio.open(path) as src:
            src.read(1, masked=True)
        gdal.append(time.perf_counter() - started)
    o, g = statistics.median(ours), statistics.median(gdal)
    print(f"{name} ({size}²): imitate {o:.2f} s, GDAL {g:.2f} s, ratio {o / g:.2f}")
