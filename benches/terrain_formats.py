"""Real rasters as they come in other formats: the hidden-teacher protocol on each
raster of ../shared/data/raster as GDAL writes it again (rasterio's CreateCopy) in the
formats a user may be handed instead of a GeoTIFF: a PNG (georeferenced by GDAL's
.aux.xml), a JPEG (quality 75, as agencies ship orthophotos, with a world file), a BIL
(ESRI .hdr and .prj), a gridded XYZ (one band; its .prj written beside it), a lossless
JPEG 2000, an ERDAS Imagine file (run-length compressed), an ENVI raster (`.dat`, by
pixel), a netCDF-4 file with Deflate (a variable per band), a GeoPackage (PNG tiles, or a
gridded coverage for one band of 16 or 32 bits). Every copy runs `imitate bench terrain` with the same seed and teachers as the
GeoTIFF; a lossless copy must give the GeoTIFF's figures to the last digit. A lossy copy
is another terrain (its teacher is drawn from the compressed image too), and an RGBA
image written as BIL (or any format keeping no alpha) is read unmasked, as GDAL reads it.

    PYTHONPATH=target/python-deps python3 benches/terrain_formats.py \
        target/release/imitate target/formats [--teacher T ...] [--seed 7]

Prints a Markdown table: raster, format, file size, held-out mean cost ratio, pairs within
1.03, within 2 cells, and whether the figures equal the GeoTIFF's.
"""

import argparse
import json
import os
import shutil
import subprocess
import warnings

import rasterio
import rasterio.errors
import rasterio.shutil
from rasterio.enums import WktVersion

warnings.filterwarnings("ignore", category=rasterio.errors.NotGeoreferencedWarning)

DATA = os.path.join(os.path.dirname(__file__), "..", "..", "shared", "data", "raster")
RASTERS = ["osgeo_spot_chicago_utm.tif", "rasterio_RGBA.uint16.tif", "rasterio_world.byte.tif"]


def copies(source, out):
    """`source` written again in every format its bands allow: (format, path, lossless)."""
    stem = os.path.join(out, os.path.splitext(os.path.basename(source))[0])
    with rasterio.open(source) as src:
        count, dtype, crs = src.count, src.dtypes[0], src.crs
    made = [("GeoTIFF", source, True)]
    if dtype in ("uint8", "uint16") and count in (1, 2, 3, 4):
        rasterio.shutil.copy(source, stem + ".png", driver="PNG")
        made.append(("PNG", stem + ".png", True))
    if dtype == "uint8" and count in (1, 3):
        rasterio.shutil.copy(source, stem + ".jpg", driver="JPEG", QUALITY=75, WORLDFILE="YES")
        made.append(("JPEG q75", stem + ".jpg", False))
    rasterio.shutil.copy(source, stem + ".bil", driver="EHdr")
    made.append(("BIL", stem + ".bil", True))
    if count == 1:
        rasterio.shutil.copy(source, stem + ".xyz", driver="XYZ")
        with open(stem + ".prj", "w") as f:
            f.write(crs.to_wkt(version=WktVersion.WKT1_ESRI))
        made.append(("XYZ", stem + ".xyz", True))
        rasterio.shutil.copy(source, stem + ".grd", driver="GS7BG")
        made.append(("Surfer 7", stem + ".grd", True))
    rasterio.shutil.copy(source, stem + ".jp2", driver="JP2OpenJPEG", QUALITY=100,
                         REVERSIBLE="YES")
    made.append(("JPEG 2000", stem + ".jp2", True))
    rasterio.shutil.copy(source, stem + ".img", driver="HFA", COMPRESSED="YES")
    made.append(("ERDAS Imagine", stem + ".img", True))
    # Its own name: an ENVI header is x.hdr, as the BIL's is.
    rasterio.shutil.copy(source, stem + "_envi.dat", driver="ENVI", INTERLEAVE="BIP")
    made.append(("ENVI", stem + "_envi.dat", True))
    rasterio.shutil.copy(source, stem + ".nc", driver="netCDF", FORMAT="NC4", COMPRESS="DEFLATE")
    made.append(("netCDF-4", stem + ".nc", True))
    # GeoPackage: 8-bit imagery in PNG tiles (a fourth band is its alpha), one band of
    # any other type as a gridded coverage (float in TIFF tiles).
    if dtype == "uint8" or (count == 1 and dtype in ("int16", "uint16", "float32")):
        tiles = "TIFF" if dtype == "float32" else "PNG"
        rasterio.shutil.copy(source, stem + ".gpkg", driver="GPKG", TILE_FORMAT=tiles)
        made.append(("GeoPackage", stem + ".gpkg", True))
    return made


def run(binary, path, teachers, seed):
    args = [binary, "bench", "terrain", path, "--method", "learch-alternate", "--seed",
            str(seed), "--json"]
    for teacher in teachers:
        args += ["--teacher", teacher]
    done = subprocess.run(args, check=True, capture_output=True, text=True)
    results = json.loads(done.stdout)["results"]
    return [r for r in results if r["method"] == "learch-alternate"]


def arguments():
    """The binary, the output folder (made), the teachers (threshold and texture unless
    named) and the seed, from the command line."""
    parser = argparse.ArgumentParser()
    parser.add_argument("binary")
    parser.add_argument("out")
    parser.add_argument("--teacher", action="append", default=[])
    parser.add_argument("--seed", type=int, default=7)
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    return args, args.teacher or ["threshold", "texture"]


def main():
    args, teachers = arguments()
    print("| raster | format | bytes | mean ratio | pairs ≤ 1.03 | within 2 cells | "
          "same figures as the GeoTIFF |")
    print("|---|---|---|---|---|---|---|")
    for name in RASTERS:
        source = os.path.join(args.out, name)
        shutil.copy(os.path.join(DATA, name), source)
        reference = None
        for label, path, _lossless in copies(source, args.out):
            results = run(args.binary, path, teachers, args.seed)
            figures = [(r["mean_cost_ratio"], r["within_radius"], r["max_cost_ratio"])
                       for r in results]
            reference = reference or figures
            mean = sum(f[0] for f in figures) / len(figures)
            within = sum(f[1] for f in figures) / len(figures)
            good = sum(f[0] <= 1.03 for f in figures)
            size = os.path.getsize(path)
            print(f"| {name} | {label} | {size:,} | {mean:.4f} | {good} of {len(figures)} | "
                  f"{within:.1%} | {'yes' if figures == reference else 'no'} |", flush=True)


if __name__ == "__main__":
    main()
