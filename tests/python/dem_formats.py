"""DEMs in the formats other than GeoTIFF that they are handed out in, written by GDAL
(rasterio) from GeoTIFFs it also writes: an Esri ASCII grid in UTM with nodata (its CRS
in the .prj beside it), one in degrees with non-square cells (GDAL's dx and dy), and an
SRTM tile (.hgt, 1201 x 1201 samples, voids), that tile zipped (.hgt.zip, as NASA hands
tiles out), DTED tiles of levels 0 and 1 (.dt0, .dt1, with voids and heights below
sea level), and gridded XYZ text (GDAL's, and one by hand with cells missing). Beside them, walks on the UTM grid and on
the tile written by pyarrow. Prints one JSON line: each pair (GeoTIFF, its twin) and
the walks."""

import json
import os
import sys
import zipfile

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import rasterio
import rasterio.shutil
from rasterio.enums import WktVersion
from rasterio.transform import from_origin

out = sys.argv[1]


def geotiff(name, values, crs, transform, nodata):
    path = os.path.join(out, name)
    with rasterio.open(path, "w", driver="GTiff", width=values.shape[1],
                       height=values.shape[0], count=1, dtype=values.dtype, crs=crs,
                       transform=transform, nodata=nodata) as dst:
        dst.write(values[None])
    return path


def twin(source, name, driver):
    path = os.path.join(out, name)
    rasterio.shutil.copy(source, path, driver=driver)
    return path


rows, cols = np.mgrid[0:30, 0:40]
dem = (1200.0 + 2.5 * rows + 10.0 * np.sin(cols / 4.0)).astype("float32")
dem[10:13, 20:24] = -9999.0
utm = geotiff("dem.tif", dem, "EPSG:32632", from_origin(400000, 5160000, 10, 10), -9999.0)
degrees = geotiff("geo.tif", (dem * 3).astype("int16"), "EPSG:4326",
                  from_origin(7.0, 47.0, 0.001, 0.0005), None)
tile = np.fromfunction(lambda r, c: 500 + (r + 2 * c) % 700, (1201, 1201)).astype("int16")
tile[600:610, 100:120] = -32768
half = 0.5 / 1200
srtm = geotiff("N46E007.tif", tile, "EPSG:4326",
               from_origin(7.0 - half, 47.0 + half, 1 / 1200, 1 / 1200), -32768)
pairs = [
    [utm, twin(utm, "dem.asc", "AAIGrid")],
    [degrees, twin(degrees, "geo.asc", "AAIGrid")],
    [srtm, twin(srtm, "N46E007.hgt", "SRTMHGT")],
]
# The tile zipped as NASA's LP DAAC hands SRTMGL3 out; GDAL reads it as it is.
zipped = os.path.join(out, "N46E007.SRTMGL3.hgt.zip")
with zipfile.ZipFile(zipped, "w", zipfile.ZIP_DEFLATED) as archive:
    archive.write(pairs[2][1], "N46E007.hgt")
with rasterio.open(zipped) as src:
    assert src.bounds.left == 7.0 - half and (src.read(1) == tile).all(), src.bounds
pairs.append([srtm, zipped])
# DTED tiles (GDAL's DTED driver), as EarthExplorer also hands SRTM out: level 0
# (121 x 121 posts of 30") with voids and heights below sea level, and level 1.
for level, posts in [(0, 121), (1, 1201)]:
    step = 1 / (posts - 1)
    heights = np.fromfunction(lambda r, c: (r * 7 + c * 3) % 900 - 200, (posts, posts))
    heights = heights.astype("int16")
    heights[40:44, 60:66] = -32767
    source = geotiff(f"N46E007_dted{level}.tif", heights, "EPSG:4326",
                     from_origin(7.0 - step / 2, 47.0 + step / 2, step, step), -32767)
    pairs.append([source, twin(source, f"n46_e007.dt{level}", "DTED")])
# Gridded XYZ, as LiDAR DEMs are handed out: GDAL's XYZ driver (and a .prj in ESRI's WKT
# for its CRS, which the format cannot hold), and one written by hand with a header, tabs,
# rows from the south and cells missing, beside GDAL's reading of it.
lidar = geotiff("lidar.tif", (dem + 0.25).clip(1100, None), "EPSG:32632",
                from_origin(400000, 5160000, 1, 1), None)
pairs.append([lidar, twin(lidar, "lidar.xyz", "XYZ")])
with rasterio.open(lidar) as src:
    open(os.path.join(out, "lidar.prj"), "w").write(src.crs.to_wkt(version=WktVersion.WKT1_ESRI))
sparse = os.path.join(out, "sparse.xyz")
with open(sparse, "w") as f:
    f.write("x\ty\televation\n")
    for row in range(12):
        for col in range(15):
            if (row * 7 + col * 3) % 11 != 0:
                f.write(f"{2500000.5 + col}\t{1100000.5 + row}\t{400 + row * 0.5 + col}\n")
with rasterio.open(sparse) as src:
    read = src.read().astype("float32")
    read[src.read_masks() == 0] = np.nan
    sparse_twin = os.path.join(out, "sparse.tif")
    with rasterio.open(sparse_twin, "w", driver="GTiff", width=src.width, height=src.height,
                       count=1, dtype="float32", transform=src.transform,
                       nodata=float("nan")) as dst:
        dst.write(read)
pairs.append([sparse_twin, sparse])

walks = {"episode": [], "map": [], "t": [], "x": [], "y": []}
for episode, map_name, points in [
    ("across-dem", "dem", [(400005.0 + 10 * k, 5159705.0) for k in range(35)]),
    ("up-the-tile", "N46E007", [(7.25, 46.1 + 0.01 * k) for k in range(40)]),
]:
    for t, (x, y) in enumerate(points):
        walks["episode"].append(episode)
        walks["map"].append(map_name)
        walks["t"].append(float(t))
        walks["x"].append(x)
        walks["y"].append(y)
demonstrations = os.path.join(out, "walks.parquet")
pq.write_table(pa.table(walks), demonstrations)
print(json.dumps({"pairs": pairs, "demonstrations": demonstrations}))
