"""Rasters of one site as they come, written by rasterio, for `ingest --stack`; and the
check of what imitate laid on the first one's grid against GDAL's own warp.

    stack_rasters.py write OUT      -> one JSON line: the files
    stack_rasters.py check OUT MAP  -> one JSON line per layer: its largest difference
                                       from GDAL's warp, over cells both hold, and the
                                       share of cells where one has data and the other not

The DEM: UTM 33N (EPSG:32633), 30 m cells. The others cover it and more: a 3-band image of
10 m cells in the same CRS (averaged onto the DEM's cells), a single band of 90 m cells
(interpolated bilinearly), and a 2-band image in degrees (EPSG:4326, about 8 m; averaged
through the CRSs). The fields are smooth, as terrain and imagery are over a few cells, so
that GDAL's weighting of partial cells and imitate's whole-cell footprints agree closely.
"""

import json
import os
import sys

import numpy as np
import rasterio
from rasterio.transform import from_origin
from rasterio.warp import Resampling, reproject, transform_bounds

WEST, NORTH = 500_000.0, 5_000_000.0
WIDTH, HEIGHT, CELL = 60, 50, 30.0


def field(xs, ys, k):
    """A smooth field of world coordinates (metres of UTM 33N)."""
    u, v = (xs - WEST) / 600.0, (ys - NORTH) / 600.0
    return 100.0 + 40.0 * np.sin(u + k) * np.cos(0.7 * v - k) + 10.0 * u


def grid(west, north, cell, width, height):
    cols, rows = np.meshgrid(np.arange(width), np.arange(height))
    return west + (cols + 0.5) * cell, north - (rows + 0.5) * cell


def write(path, crs, transform, bands):
    data = np.stack(bands).astype("float32")
    with rasterio.open(path, "w", driver="GTiff", width=data.shape[2], height=data.shape[1],
                       count=data.shape[0], dtype="float32", crs=crs, transform=transform,
                       nodata=-9999.0) as dst:
        dst.write(data)


def main_write(out):
    files = {}
    xs, ys = grid(WEST, NORTH, CELL, WIDTH, HEIGHT)
    files["dem"] = os.path.join(out, "dem.tif")
    write(files["dem"], "EPSG:32633", from_origin(WEST, NORTH, CELL, CELL), [field(xs, ys, 0.0)])
    # Finer, same CRS, reaching 150 m past the DEM on every side.
    west, north, cell = WEST - 150.0, NORTH + 150.0, 10.0
    width, height = int((WIDTH * CELL + 300) / cell), int((HEIGHT * CELL + 300) / cell)
    xs, ys = grid(west, north, cell, width, height)
    files["ortho"] = os.path.join(out, "ortho.tif")
    write(files["ortho"], "EPSG:32633", from_origin(west, north, cell, cell),
          [field(xs, ys, k) for k in (1.0, 2.0, 3.0)])
    # Coarser, same CRS, offset by a third of its cell.
    west, north, cell = WEST - 270.0, NORTH + 300.0, 90.0
    width, height = 26, 24
    xs, ys = grid(west, north, cell, width, height)
    files["coarse"] = os.path.join(out, "coarse.tif")
    write(files["coarse"], "EPSG:32633", from_origin(west, north, cell, cell),
          [field(xs, ys, 4.0)])
    # In degrees: the DEM's bounds and a margin, cells of about 8 m.
    left, bottom, right, top = transform_bounds(
        "EPSG:32633", "EPSG:4326", WEST - 200, NORTH - HEIGHT * CELL - 200,
        WEST + WIDTH * CELL + 200, NORTH + 200)
    dx, dy = 1e-4, 7e-5
    width, height = int((right - left) / dx) + 1, int((top - bottom) / dy) + 1
    lon, lat = grid(left, top, 0.0, width, height)
    lon = left + (np.arange(width)[None, :] + 0.5) * dx + 0 * lat
    lat = top - (np.arange(height)[:, None] + 0.5) * dy + 0 * lon
    from rasterio.warp import transform as move
    ux, uy = move("EPSG:4326", "EPSG:32633", lon.ravel(), lat.ravel())
    ux, uy = np.reshape(ux, lon.shape), np.reshape(uy, lat.shape)
    files["gps_ortho"] = os.path.join(out, "gps_ortho.tif")
    transform = rasterio.transform.Affine(dx, 0, left, 0, -dy, top)
    write(files["gps_ortho"], "EPSG:4326", transform, [field(ux, uy, k) for k in (5.0, 6.0)])
    print(json.dumps(files))


def main_check(out, map_path):
    import pyarrow.parquet as pq

    table = pq.read_table(map_path)
    with rasterio.open(os.path.join(out, "dem.tif")) as dem:
        dst_crs, dst_transform = dem.crs, dem.transform
    checks = [("ortho", "ortho.tif", 3, Resampling.average),
              ("coarse", "coarse.tif", 1, Resampling.bilinear),
              ("gps_ortho", "gps_ortho.tif", 2, Resampling.average)]
    for stem, name, count, resampling in checks:
        with rasterio.open(os.path.join(out, name)) as src:
            for band in range(1, count + 1):
                layer = stem if count == 1 else f"{stem}_band{band}"
                expected = np.full((HEIGHT, WIDTH), np.nan, dtype="float32")
                reproject(rasterio.band(src, band), expected, dst_transform=dst_transform,
                          dst_crs=dst_crs, dst_nodata=np.nan, resampling=resampling)
                # imitate's rows run south to north.
                got = np.asarray(table[layer]).reshape(HEIGHT, WIDTH)[::-1]
                both = ~np.isnan(expected) & ~np.isnan(got)
                print(json.dumps({
                    "layer": layer,
                    "max_difference": float(np.max(np.abs(expected[both] - got[both]))),
                    "range": float(np.nanmax(expected) - np.nanmin(expected)),
                    "data_disagree": float(np.mean(np.isnan(expected) != np.isnan(got))),
                }))


if __name__ == "__main__":
    if sys.argv[1] == "write":
        main_write(sys.argv[2])
    else:
        main_check(sys.argv[2], sys.argv[3])
