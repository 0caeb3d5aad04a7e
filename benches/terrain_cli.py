#!/usr/bin/env python3
"""The hidden-teacher protocol as a user runs it: through the CLI, scored outside the tool.

`imitate bench terrain` draws its teacher paths, learns and scores inside one process.
This script does what someone checking the tool would: resamples a GeoTIFF with GDAL
(rasterio, average), makes a teacher cost of its own from the bands, draws optimal
teacher paths with its own Dijkstra (8-connected, a step costs its length on the
ground times the mean of its two cells' costs; on a geographic raster a row's cells
are measured in metres at its latitude, as the issue asks of the tool; cells without
data stay no-data in the map the tool reads, cost the teacher 12 and hold no path's
ends), writes three quarters of them as a demonstrations table of world coordinates,
and runs

    imitate ingest --map MAP.tif --demonstrations train.parquet --out ds   (--geojson train.geojson with --drawn)
    imitate features --dataset ds --bank auto --out fs
    imitate learch --dataset ds --features fs --out costmap [LEARCH_ARGS]
    imitate export costmap --format geotiff --out export

then plans the held-out quarter's ends on the exported costmap with the same Dijkstra
and scores the plans under the teacher's cost: mean and worst true-cost ratio (plan /
teacher path) and the share of planned cells within 2 cells of the teacher's path.

    python3 benches/terrain_cli.py IMITATE RASTER WORKDIR [--teacher bright|contrast]
        [--cells 160] [--paths 60] [--seed 7] [--in-tool] [--jitter CELLS] [--poses-per-cell K]
        [--drawn K]
        [-- LEARCH_ARGS...]

With `--in-tool` the tool is given the raster as it is and coarsens it itself
(`ingest --cells`); the script's teacher lives on GDAL's grid of the same blocks
(rasterio's `reproject` to the transform scaled by the factor, `average`), which is the
grid the tool's costmap comes back on. With `--jitter CELLS` the demonstrations' poses
wander off the teacher's cells by a drift of that many cells (correlated over about
five poses), as a real track does. With `--drawn K` the demonstrations are routes drawn
by hand instead: GeoJSON LineStrings in longitude and latitude with a vertex every K
cells of the teacher's path (`ingest --geojson`), as someone clicks a route in QGIS.

Needs numpy, pyarrow and rasterio (`scripts/python-deps.sh` installs them).
"""
import argparse
import heapq
import json
import math
import os
import subprocess
import sys

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import rasterio
from rasterio.enums import Resampling
from rasterio.transform import Affine
from rasterio.warp import reproject
from rasterio.warp import transform as warp_transform


def resampled(raster, cells, out, whole_blocks=False):
    """The raster averaged down to `cells` along its longer side, as a float32 GeoTIFF
    whose cells without data (in any band) are NaN, tagged as its nodata; its CRS. With
    `whole_blocks`, on GDAL's grid of blocks of whole cells from the north-west corner
    (the last ones clipped), as `imitate ingest --cells` coarsens."""
    with rasterio.open(raster) as src:
        factor = max(1, math.ceil(max(src.width, src.height) / cells))
        if whole_blocks:
            shape = (src.count, -(-src.height // factor), -(-src.width // factor))
            transform = src.transform * Affine.scale(factor)
            fine = src.read(masked=True).astype("float32").filled(np.nan)
            data = np.full(shape, np.nan, dtype="float32")
            for band in range(src.count):
                reproject(fine[band], data[band], src_transform=src.transform,
                          src_crs=src.crs, src_nodata=np.nan, dst_transform=transform,
                          dst_crs=src.crs, dst_nodata=np.nan,
                          resampling=Resampling.average)
        else:
            shape = (src.count, src.height // factor, src.width // factor)
            data = src.read(out_shape=shape, resampling=Resampling.average, masked=True)
            data = data.astype("float32").filled(np.nan)
            transform = src.transform * src.transform.scale(
                src.width / shape[2], src.height / shape[1])
        data[:, np.isnan(data).any(axis=0)] = np.nan
        profile = dict(driver="GTiff", width=shape[2], height=shape[1], count=shape[0],
                       dtype="float32", crs=src.crs, transform=transform, nodata=np.nan)
        crs = src.crs
    with rasterio.open(out, "w", **profile) as dst:
        dst.write(data)
    return data, transform, crs


def row_metres(transform, crs, rows):
    """Each row's cell width and the cells' height, in metres: on a geographic raster
    from the latitude of the row's centre (WGS 84's metres per degree), else the
    transform's own units."""
    dx, dy = abs(transform.a), abs(transform.e)
    if crs is None or not crs.is_geographic:
        return np.full(rows, dx), np.full(rows, dy)
    lat = np.radians(transform.f + transform.e * (np.arange(rows) + 0.5))
    per_lat = 111132.92 - 559.82 * np.cos(2 * lat) + 1.175 * np.cos(4 * lat)
    per_lon = 111412.84 * np.cos(lat) - 93.5 * np.cos(3 * lat)
    return dx * per_lon, dy * per_lat


def normalised(bands):
    """Every band scaled to its own 2nd-98th percentile, clipped to [0, 1] (NaN stays)."""
    out = []
    for b in bands:
        lo, hi = np.nanpercentile(b, [2, 98])
        out.append(np.clip((b - lo) / max(hi - lo, 1e-9), 0, 1))
    return out


def box_mean(x, radius):
    """Mean over a (2r+1)² window, edges replicated."""
    padded = np.pad(x, radius, mode="edge")
    total = np.zeros_like(x)
    for dr in range(2 * radius + 1):
        for dc in range(2 * radius + 1):
            total += padded[dr:dr + x.shape[0], dc:dc + x.shape[1]]
    return total / (2 * radius + 1) ** 2


def teacher_cost(bands, teacher):
    """The teacher's cost per cell; cells without data cost 12."""
    n = normalised(bands)
    brightness = sum(n) / len(n)
    void = np.isnan(brightness)
    if teacher == "bright":
        # Thresholds the tool never sees: bright ground dear, the darkest dearer still.
        cost = 1 + 5 * (brightness > 0.55) + 2 * (brightness < 0.2)
    else:
        # contrast: a cell unlike its 7 x 7 neighbourhood is dear, squared.
        filled = np.where(void, np.nanmedian(brightness), brightness)
        cost = 1 + 40 * (filled - box_mean(filled, 3)) ** 2 + 2 * (n[0] > 0.7)
    return np.where(void, 12.0, cost)


def step_length(dx, dy, r0, c0, r1, c1):
    """A step's length on the ground: the mean of its two rows' cell widths across."""
    return math.hypot((c1 - c0) * 0.5 * (dx[r0] + dx[r1]), (r1 - r0) * dy[r0])


def dijkstra(cost, dx, dy, start, goal):
    """Cheapest 8-connected path from `start` to `goal` (row, col); NaN cells are walls."""
    h, w = cost.shape
    moves = [(-1, 0), (0, -1), (0, 1), (1, 0), (-1, -1), (-1, 1), (1, -1), (1, 1)]
    dist = np.full(cost.shape, np.inf)
    parent = {}
    dist[start] = 0.0
    queue = [(0.0, start)]
    while queue:
        d, (r, c) = heapq.heappop(queue)
        if (r, c) == goal:
            break
        if d > dist[r, c]:
            continue
        for dr, dc in moves:
            rr, cc = r + dr, c + dc
            if 0 <= rr < h and 0 <= cc < w:
                length = step_length(dx, dy, r, c, rr, cc)
                nd = d + length * 0.5 * (cost[r, c] + cost[rr, cc])
                if nd < dist[rr, cc]:
                    dist[rr, cc] = nd
                    parent[(rr, cc)] = (r, c)
                    heapq.heappush(queue, (nd, (rr, cc)))
    path = [goal]
    while path[-1] != start:
        path.append(parent[path[-1]])
    return path[::-1]


def path_cost(cost, dx, dy, path):
    total = 0.0
    for (r0, c0), (r1, c1) in zip(path, path[1:]):
        length = step_length(dx, dy, r0, c0, r1, c1)
        total += length * 0.5 * (cost[r0, c0] + cost[r1, c1])
    return total


def within(plan, teacher, radius=2.0):
    cells = np.array(teacher)
    near = 0
    for r, c in plan:
        if (((cells[:, 0] - r) ** 2 + (cells[:, 1] - c) ** 2).min()) <= radius ** 2:
            near += 1
    return near


def jitter(rng, n, cells):
    """A drift of `cells` standard deviation per axis, correlated over about five
    poses, as a GNSS or odometry track wanders around where the robot went."""
    if cells == 0:
        return np.zeros((n, 2))
    white = rng.standard_normal((n + 30, 2))
    kernel = np.exp(-0.5 * (np.arange(-15, 16) / 5.0) ** 2)
    smooth = np.stack([np.convolve(white[:, k], kernel, mode="same") for k in (0, 1)],
                      axis=1)[15:15 + n]
    return smooth / smooth.std() * cells


def main():
    argv = sys.argv[1:]
    extra = argv[argv.index("--") + 1:] if "--" in argv else []
    argv = argv[:argv.index("--")] if "--" in argv else argv
    parser = argparse.ArgumentParser()
    parser.add_argument("imitate")
    parser.add_argument("raster")
    parser.add_argument("workdir")
    parser.add_argument("--teacher", choices=["bright", "contrast"], default="bright")
    parser.add_argument("--cells", type=int, default=160)
    parser.add_argument("--paths", type=int, default=60)
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--in-tool", action="store_true")
    parser.add_argument("--jitter", type=float, default=0.0,
                        help="poses off the teacher's cells by a drift of this many cells")
    parser.add_argument("--drawn", type=int, default=0, metavar="K",
                        help="give the demonstrations as routes drawn by hand: GeoJSON "
                             "LineStrings in longitude and latitude (RFC 7946) with a vertex "
                             "every K cells of the teacher's path and at its ends, read with "
                             "ingest --geojson")
    parser.add_argument("--poses-per-cell", type=int, default=1,
                        help="poses logged per step of the path, on straight lines between "
                             "its cells, each path a fixed sub-cell offset off their centres "
                             "(a densely logged track)")
    args = parser.parse_args(argv)
    os.makedirs(args.workdir, exist_ok=True)
    name = "terrain"
    map_path = os.path.join(args.workdir, f"{name}.tif")
    if os.path.islink(map_path):  # a link to the raster, left by a run with --in-tool
        os.remove(map_path)
    bands, transform, crs = resampled(args.raster, args.cells, map_path, args.in_tool)
    cost = teacher_cost(list(bands), args.teacher).astype("float64")
    h, w = cost.shape
    dx, dy = row_metres(transform, crs, h)
    void = np.isnan(bands).any(axis=0)

    rng = np.random.default_rng(args.seed)
    paths = []
    while len(paths) < args.paths:
        a = (int(rng.integers(h)), int(rng.integers(w)))
        b = (int(rng.integers(h)), int(rng.integers(w)))
        if math.dist(a, b) < 0.5 * min(h, w) or void[a] or void[b]:
            continue
        paths.append(dijkstra(cost, dx, dy, a, b))
    held = set(range(3, args.paths, 4))
    rows = {"episode": [], "map": [], "t": [], "x": [], "y": []}
    drawn = []
    for i, path in enumerate(paths):
        if i in held:
            continue
        drift = jitter(rng, len(path), args.jitter)
        centres = np.array(path, dtype="float64")[:, ::-1] + 0.5 + drift
        if args.poses_per_cell > 1:
            k = args.poses_per_cell
            steps = np.arange(k * (len(path) - 1) + 1) / k
            centres = np.stack([np.interp(steps, np.arange(len(path)), centres[:, a])
                                for a in (0, 1)], axis=1)
            centres += rng.uniform(-0.3, 0.3, size=2)
        if args.drawn:
            vertices = sorted(set(range(0, len(centres), args.drawn)) | {len(centres) - 1})
            xs, ys = zip(*(transform * tuple(centres[k]) for k in vertices))
            lons, lats = warp_transform(crs, "EPSG:4326", list(xs), list(ys))
            drawn.append({"type": "Feature", "properties": {"name": f"teacher-{i:03}"},
                          "geometry": {"type": "LineString",
                                       "coordinates": [list(p) for p in zip(lons, lats)]}})
            continue
        for t, (col, row) in enumerate(centres):
            col = min(max(col, 0.01), w - 0.01)
            row = min(max(row, 0.01), h - 0.01)
            x, y = transform * (col, row)
            rows["episode"].append(f"teacher-{i:03}")
            rows["map"].append(name)
            rows["t"].append(float(t))
            rows["x"].append(x)
            rows["y"].append(y)
    if args.drawn:
        with open(os.path.join(args.workdir, "train.geojson"), "w") as f:
            json.dump({"type": "FeatureCollection", "features": drawn}, f)
        given = ["--geojson", "train.geojson"]
    else:
        pq.write_table(pa.table(rows), os.path.join(args.workdir, "train.parquet"))
        given = ["--demonstrations", "train.parquet"]

    def imitate(*cli):
        subprocess.run([args.imitate, *cli], cwd=args.workdir, check=True,
                       stdout=subprocess.DEVNULL)

    if args.in_tool:
        os.replace(map_path, os.path.join(args.workdir, "teacher-grid.tif"))
        os.symlink(os.path.abspath(args.raster), map_path)
        coarsen = ["--cells", str(args.cells)]
    else:
        coarsen = []
    imitate("ingest", "--map", f"{name}.tif", *given, "--out", "ds", *coarsen)
    imitate("features", "--dataset", "ds", "--bank", "auto", "--out", "fs")
    imitate("learch", "--dataset", "ds", "--features", "fs", "--out", "costmap", *extra)
    imitate("export", "costmap", "--format", "geotiff", "--out", "export")
    exported = [f for f in os.listdir(os.path.join(args.workdir, "export"))
                if f.endswith(".tif")]
    with rasterio.open(os.path.join(args.workdir, "export", exported[0])) as src:
        learned = src.read(1).astype("float64")
        assert src.transform.almost_equals(transform), (src.transform, transform)
    assert learned.shape == cost.shape, (learned.shape, cost.shape)

    ratios, near, planned = [], 0, 0
    for i in sorted(held):
        teacher = paths[i]
        plan = dijkstra(learned, dx, dy, teacher[0], teacher[-1])
        ratios.append(path_cost(cost, dx, dy, plan) / path_cost(cost, dx, dy, teacher))
        near += within(plan, teacher)
        planned += len(plan)
    print(json.dumps({
        "raster": os.path.basename(args.raster), "teacher": args.teacher,
        "learch_args": extra, "drawn": args.drawn, "jitter": args.jitter,
        "held_out": len(ratios),
        "mean_cost_ratio": sum(ratios) / len(ratios), "max_cost_ratio": max(ratios),
        "within_radius": near / planned,
    }))


if __name__ == "__main__":
    main()
