"""GPS tracks as a hiker's apps export them, on a DEM in UTM: a raster in EPSG:32632
(rasterio), and GPX files written by gpxpy, one in GPX 1.1 (two tracks, the second of
two segments, one of them a single fix; times with repeated seconds) and one in GPX 1.0
(speed and course elements, no times), and the DEM again in 1 m cells. Prints one JSON
line: the files, and for every episode the ingest should make, the cells of its first
and last fix as rasterio's PROJ and the raster's transform put them (rows counted from
the south edge, as imitate's)."""

import json
import os
import sys
from datetime import datetime, timedelta, timezone

import gpxpy
import gpxpy.gpx
import numpy as np
import rasterio
from rasterio.transform import from_origin, rowcol
from rasterio.warp import transform

out = sys.argv[1]
west, north, cell = 400000.0, 5160000.0, 10.0  # UTM 32N, near 46.6° N 7.7° E
height, width = 60, 80
dem = np.fromfunction(lambda r, c: 1500.0 + 3.0 * r + np.sin(c / 5.0) * 20.0, (height, width))
raster = os.path.join(out, "dem.tif")
with rasterio.open(raster, "w", driver="GTiff", width=width, height=height, count=1,
                   dtype="float32", crs="EPSG:32632",
                   transform=from_origin(west, north, cell, cell)) as dst:
    dst.write(dem.astype("float32")[None])
# The same ground in 1 m cells, finer than GPS fixes are good to.
fine = os.path.join(out, "fine.tif")
with rasterio.open(fine, "w", driver="GTiff", width=width * 10, height=height * 10, count=1,
                   dtype="float32", crs="EPSG:32632",
                   transform=from_origin(west, north, 1.0, 1.0)) as dst:
    dst.write(np.kron(dem, np.ones((10, 10))).astype("float32")[None])


def fixes(cells):
    """Longitude and latitude of the centres of (row, col) cells."""
    xs = [west + (c + 0.5) * cell for _, c in cells]
    ys = [north - (r + 0.5) * cell for r, _ in cells]
    return list(zip(*transform("EPSG:32632", "EPSG:4326", xs, ys)))


def line(r0, c0, r1, c1, n):
    return [(round(r0 + (r1 - r0) * k / (n - 1)), round(c0 + (c1 - c0) * k / (n - 1)))
            for k in range(n)]


start = datetime(2024, 5, 1, 8, 0, 0, tzinfo=timezone.utc)
walks = {
    "ridge-track-000": line(5, 5, 50, 70, 40),
    "ridge-track-001-000": line(55, 10, 10, 60, 30),
    "valley-track-000": line(30, 2, 30, 77, 25),
}

ridge = gpxpy.gpx.GPX()
for name, segments in [("ridge-track-000", [walks["ridge-track-000"]]),
                       ("ridge-track-001", [walks["ridge-track-001-000"], [(20, 20)]])]:
    track = gpxpy.gpx.GPXTrack(name=name)
    ridge.tracks.append(track)
    for cells in segments:
        segment = gpxpy.gpx.GPXTrackSegment()
        track.segments.append(segment)
        for k, (lon, lat) in enumerate(fixes(cells)):
            # Two fixes a second at the start, as 1 Hz loggers repeat a stamp.
            when = start + timedelta(seconds=max(k - 1, 0))
            segment.points.append(gpxpy.gpx.GPXTrackPoint(lat, lon, elevation=1500.0, time=when))
ridge_path = os.path.join(out, "ridge.gpx")
with open(ridge_path, "w") as f:
    f.write(ridge.to_xml(version="1.1"))

valley = gpxpy.gpx.GPX()
track = gpxpy.gpx.GPXTrack()
valley.tracks.append(track)
segment = gpxpy.gpx.GPXTrackSegment()
track.segments.append(segment)
for lon, lat in fixes(walks["valley-track-000"]):
    point = gpxpy.gpx.GPXTrackPoint(lat, lon, speed=1.2)
    point.course = 90.0
    segment.points.append(point)
valley_path = os.path.join(out, "valley.gpx")
with open(valley_path, "w") as f:
    f.write(valley.to_xml(version="1.0"))


def cell_of(lon, lat):
    (x,), (y,) = transform("EPSG:4326", "EPSG:32632", [lon], [lat])
    row, col = rowcol(from_origin(west, north, cell, cell), x, y)
    return [height - 1 - int(row), int(col)]  # imitate counts rows from the south edge


ends = {}
for name, cells in walks.items():
    points = fixes(cells)
    ends[name] = [cell_of(*points[0]), cell_of(*points[-1])]
print(json.dumps({"raster": raster, "fine": fine, "gpx": [ridge_path, valley_path], "ends": ends}))
