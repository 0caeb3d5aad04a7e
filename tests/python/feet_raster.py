"""A DEM-like raster in New York State Plane (Long Island, EPSG:2263: coordinates in US
survey feet), written by rasterio, and demonstrations beside it as a GIS user has them:
poses in the same CRS, in feet, written by pyarrow, and the same poses as a GPS logs
them (longitude and latitude, EPSG:4326, moved by rasterio's PROJ). Prints one JSON line:
the files, the grid, and a start and goal in feet and in longitude and latitude."""

import json
import os
import sys

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import rasterio
from rasterio.transform import from_origin
from rasterio.warp import transform

out = sys.argv[1]
west, north, cell = 980000.0, 200000.0, 50.0  # feet; Manhattan's latitude, in the zone
height, width = 30, 40
rows, cols = np.mgrid[0:height, 0:width]
# A ridge across the middle columns: dear to cross but where it dips, at rows 20-24.
band = np.where((abs(cols - 20) <= 1) & ~((rows >= 20) & (rows <= 24)), 200.0, 10.0)
raster = os.path.join(out, "feet.tif")
with rasterio.open(raster, "w", driver="GTiff", width=width, height=height, count=1,
                   dtype="float32", crs="EPSG:2263",
                   transform=from_origin(west, north, cell, cell)) as dst:
    dst.write(band.astype("float32")[None])


def centre(row, col):
    return west + (col + 0.5) * cell, north - (row + 0.5) * cell


episodes = {"episode": [], "map": [], "t": [], "x": [], "y": []}
for episode, row in enumerate([5, 10, 27]):
    # Along column 2 to the gap's row, then east through the gap in the ridge.
    step = 1 if row < 22 else -1
    cells = [(r, 2) for r in range(row, 22, step)] + [(22, c) for c in range(2, 38)]
    for t, (r, c) in enumerate(cells):
        x, y = centre(r, c)
        episodes["episode"].append(f"walk-{episode}")
        episodes["map"].append("feet")
        episodes["t"].append(float(t))
        episodes["x"].append(x)
        episodes["y"].append(y)
demonstrations = os.path.join(out, "walks.parquet")
pq.write_table(pa.table(episodes), demonstrations)
longitudes, latitudes = transform("EPSG:2263", "EPSG:4326", episodes["x"], episodes["y"])
gps = os.path.join(out, "walks_gps.parquet")
pq.write_table(pa.table({**episodes, "x": longitudes, "y": latitudes}), gps)
start, goal = centre(15, 3), centre(15, 36)
ends_lon, ends_lat = transform("EPSG:2263", "EPSG:4326", [start[0], goal[0]], [start[1], goal[1]])
print(json.dumps({
    "raster": raster, "demonstrations": demonstrations, "gps": gps,
    "bounds": [west, north - height * cell, west + width * cell, north],
    "start": list(start), "goal": list(goal),
    "start_gps": [ends_lon[0], ends_lat[0]], "goal_gps": [ends_lon[1], ends_lat[1]],
}))
