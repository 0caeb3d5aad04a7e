"""Routes an expert drew over a map, saved as QGIS saves a line layer: GeoJSON written
by GDAL's OGR (pyogrio), once in the layer's CRS (UTM 32N, with the legacy crs member
OGR writes) and once as RFC 7946 asks (WGS 84 longitude and latitude, 7 decimals), the
last route a MultiLineString of two strokes; the same routes as GeoPackage line layers
(as QGIS saves a new layer), in UTM and in WGS 84, with Z; as KML from GDAL's KML and
LIBKML drivers and as LIBKML's KMZ; the first two as a GPX track's points converted
to GeoJSON by GDAL; a GeoPackage of points alone.
Beside them a DEM in the same UTM zone (rasterio). Prints one JSON line: the files and
the routes' names in order."""

import json
import os
import sys

import numpy as np
import pyogrio.raw
import rasterio
import shapely
from rasterio.transform import from_origin

out = sys.argv[1]
west, north, cell = 400000.0, 5160000.0, 10.0
height, width = 50, 70
dem = np.fromfunction(lambda r, c: 900.0 + 4.0 * r + 15.0 * np.cos(c / 6.0), (height, width))
raster = os.path.join(out, "site.tif")
with rasterio.open(raster, "w", driver="GTiff", width=width, height=height, count=1,
                   dtype="float32", crs="EPSG:32632",
                   transform=from_origin(west, north, cell, cell)) as dst:
    dst.write(dem.astype("float32")[None])


def at(row, col):
    """A point inside cell (row from the north, col), off its centre."""
    return west + (col + 0.3) * cell, north - (row + 0.6) * cell


routes = [
    ("north-east", shapely.LineString([at(2, 3), at(20, 30), at(25, 60)])),
    ("valley", shapely.LineString([at(40, 2), at(40, 66)])),
    ("two strokes", shapely.MultiLineString([[at(45, 5), at(30, 25)], [at(30, 25), at(10, 50)]])),
]
names = np.array([name for name, _ in routes], dtype=object)
geometry = np.array([shapely.to_wkb(line) for _, line in routes], dtype=object)
files = {}
for kind, options in [("utm", {}), ("wgs84", {"RFC7946": "YES"})]:
    path = os.path.join(out, f"routes_{kind}.geojson")
    pyogrio.raw.write(path, geometry=geometry, field_data=[names], fields=["name"],
                      crs="EPSG:32632", driver="GeoJSON", geometry_type="Unknown",
                      layer_options=options)
    files[kind] = path

# The same routes as QGIS saves a new line layer by default: a GeoPackage, in the
# layer's UTM CRS and in WGS 84 (the RFC 7946 file's coordinates, moved there by GDAL),
# the lines written with Z as a GPS-snapped layer has them.
for kind, crs in [("utm", "EPSG:32632"), ("wgs84", "EPSG:4326")]:
    _, _, wkb, _ = pyogrio.raw.read(files[kind])
    lines = [shapely.force_3d(shapely.from_wkb(g), 1200.0) for g in wkb]
    path = os.path.join(out, f"routes_{kind}.gpkg")
    pyogrio.raw.write(path, geometry=np.array([shapely.to_wkb(line) for line in lines],
                                              dtype=object),
                      field_data=[names], fields=["name"], crs=crs, driver="GPKG",
                      geometry_type="Unknown", layer="routes")
    files[f"gpkg_{kind}"] = path
# The same routes as Google Earth keeps them: KML from GDAL's KML and LIBKML drivers,
# and LIBKML's zipped KMZ (WGS 84, as KML fixes it; the MultiLineString a
# MultiGeometry of two LineStrings).
_, _, wkb, _ = pyogrio.raw.read(files["wgs84"])
for kind, driver, name in [("kml", "KML", "routes.kml"), ("libkml", "LIBKML", "routes_libkml.kml"),
                           ("kmz", "LIBKML", "routes.kmz")]:
    path = os.path.join(out, name)
    pyogrio.raw.write(path, geometry=np.array(wkb, dtype=object), field_data=[names],
                      fields=["Name"], crs="EPSG:4326", driver=driver, geometry_type="Unknown",
                      layer="routes")
    files[kind] = path
# The two single-stroke routes as a recorded track's points, as GDAL converts a GPX
# file's `track_points` layer to GeoJSON (ogr2ogr ... track_points): one Point a fix,
# with `track_fid`, `track_seg_id` and `time`.
fids, segments, times, vertices = [], [], [], []
for fid, (name, line) in enumerate(routes[:2]):
    for k, (x, y) in enumerate(line.coords):
        fids.append(fid)
        segments.append(0)
        times.append(f"2024-05-01T10:{fid:02d}:{3 * k:02d}Z")
        vertices.append(shapely.to_wkb(shapely.Point(x, y)))
track_points = os.path.join(out, "track_points.geojson")
pyogrio.raw.write(track_points, geometry=np.array(vertices, dtype=object),
                  field_data=[np.array(fids), np.array(segments), np.array(times, dtype=object)],
                  fields=["track_fid", "track_seg_id", "time"], crs="EPSG:32632",
                  driver="GeoJSON", geometry_type="Point")
files["track_points"] = track_points
points = os.path.join(out, "points.gpkg")
pyogrio.raw.write(points, geometry=np.array([shapely.to_wkb(shapely.Point(at(3, 3)))],
                                            dtype=object),
                  field_data=[], fields=[], crs="EPSG:32632", driver="GPKG",
                  geometry_type="Point", layer="fixes")
print(json.dumps({"raster": raster, **files, "points_gpkg": points,
                  "episodes": ["north-east", "valley", "two strokes-0", "two strokes-1"]}))
