"""Real imagery as an MBTiles package: the 8-bit rasters of ../shared/data/raster written
by GDAL's MBTiles driver (rasterio's CreateCopy: warped to Web Mercator at the zoom level
nearest their cells, PNG or JPEG tiles), each run through the hidden-teacher protocol
beside a GeoTIFF twin of what GDAL reads the package to (its colour bands, one where the
source is grey; NaN where its alpha is 0). A package with PNG tiles must give its twin's figures to the last digit; one
with JPEG tiles is decoded by another decoder than GDAL's, so its figures may differ in
near-equal plans. Each PNG package is also converted to a PMTiles archive (Protomaps'
converter) and run beside the package.

    PYTHONPATH=target/python-deps python3 benches/terrain_mbtiles.py \
        target/release/imitate target/mbtiles [--teacher T ...] [--seed 7]

Prints a Markdown table: raster, tiles, zoom level, cells, the package's held-out mean
cost ratio, pairs within 1.03 and share within 2 cells, the twin's, and whether they are
the same.
"""

import os
import sqlite3
import sys

import rasterio
import rasterio.shutil
from pmtiles.convert import mbtiles_to_pmtiles

from terrain_formats import arguments, run

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tests", "python"))
from gdal_twin import imagery_twin  # noqa: E402

DATA = os.path.join(os.path.dirname(__file__), "..", "..", "shared", "data", "raster")
RASTERS = ["osgeo_spot_chicago_utm.tif", "rasterio_world.byte.tif"]


def figures(binary, path, teachers, seed):
    """The default method's held-out mean ratio, pairs ≤ 1.03 and share within 2 cells,
    and each pair's figures (to compare to the last digit)."""
    results = run(binary, path, teachers, seed)
    pairs = [(r["mean_cost_ratio"], r["within_radius"], r["max_cost_ratio"]) for r in results]
    ratios = [p[0] for p in pairs]
    summary = (sum(ratios) / len(ratios), sum(x <= 1.03 for x in ratios), len(ratios),
               100 * sum(p[1] for p in pairs) / len(pairs))
    return summary, pairs


def main():
    args, teachers = arguments()
    print("| raster | tiles | zoom | cells | MBTiles ratio / ≤ 1.03 / within 2 | "
          "GDAL's reading as GeoTIFF | same |")
    print("|---|---|---|---|---|---|---|")
    for name in RASTERS:
        source = os.path.join(DATA, name)
        for tiles in ["PNG", "JPEG"]:
            path = os.path.join(args.out, f"{os.path.splitext(name)[0]}_{tiles.lower()}.mbtiles")
            if os.path.exists(path):
                os.remove(path)
            rasterio.shutil.copy(source, path, driver="MBTiles", TILE_FORMAT=tiles)
            with rasterio.open(path) as src:
                cells = src.width * src.height
            db = sqlite3.connect(path)
            (zoom,) = db.execute("SELECT MAX(zoom_level) FROM tiles").fetchone()
            db.close()
            with rasterio.open(source) as src:
                colours = 1 if src.count < 3 else 3
            twin, _ = imagery_twin(path, colours)
            ours, our_pairs = figures(args.binary, path, teachers, args.seed)
            gdal, gdal_pairs = figures(args.binary, twin, teachers, args.seed)
            show = lambda f: f"{f[0]:.4f} / {f[1]} of {f[2]} / {f[3]:.1f}%"
            print(f"| {name} | {tiles} | {zoom} | {cells:,} | {show(ours)} | {show(gdal)} | "
                  f"{'yes' if our_pairs == gdal_pairs else 'no'} |", flush=True)
            if tiles == "PNG":
                # The package as a PMTiles archive (its bounds kept to 7 decimals).
                archive = os.path.splitext(path)[0] + ".pmtiles"
                mbtiles_to_pmtiles(path, archive, None)
                theirs, their_pairs = figures(args.binary, archive, teachers, args.seed)
                print(f"| {name} | PNG, as PMTiles | {zoom} | {cells:,} | {show(theirs)} | "
                      f"{show(ours)} (the MBTiles) | "
                      f"{'yes' if their_pairs == our_pairs else 'no'} |", flush=True)


if __name__ == "__main__":
    main()
