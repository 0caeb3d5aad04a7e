"""Real rasters as they come in other formats: the hidden-teacher protocol on each
raster of ../shared/data/raster as GDAL writes it again (rasterio's CreateCopy) in the
formats a user may be handed instead of a GeoTIFF: a PNG (georeferenced by GDAL's
.aux.xml), a JPEG (quality 75, as agencies ship orthophotos, with a world file), a BIL
(ESRI .hdr and .prj), a gridded XYZ (one band; its .prj written beside it), a lossless
JPEG 2000, an ERDAS Imagine file (run-length compressed), an ENVI raster (`.dat`, by
pixel), a netCDF-4 file with Deflate (a variable per band), a GeoPackage (PNG tiles, or a
gridded coverage for one band of 16 or 32 bits), a SAGA grid (one band; also zipped as
SAGA's `.sg-grd-z`), an R raster grid (`.grd` beside `.gri`), Zarr stores (versions 2
and 3, as xarray writes a raster's bands). Every copy runs `imitate bench terrain` with the same seed and teachers as the
GeoTIFF; a lossless copy must give the GeoTIFF's figures to the last digit. A lossy copy
is another terrain (its teacher is drawn from the compressed image too), and an RGBA
image written as BIL (or any format keeping no alpha) is read unmasked, as GDAL reads it.

    PYTHONPATH=target/python-deps python3 benches/terrain_formats.py \
        target/release/imitate target/formats [--teacher T ...] [--seed 7] \
        [--raster PATH ...] [--format LABEL ...]

Prints a Markdown table: raster, format, file size, held-out mean cost ratio, pairs within
1.03, within 2 cells, and whether the figures equal the GeoTIFF's.
"""

import argparse
import json
import os
import shutil
import subprocess
import warnings
import zipfile

import rasterio
import rasterio.errors
import rasterio.shutil
from rasterio.enums import WktVersion

warnings.filterwarnings("ignore", category=rasterio.errors.NotGeoreferencedWarning)

DATA = os.path.join(os.path.dirname(__file__), "..", "..", "shared", "data", "raster")
RASTERS = ["osgeo_spot_chicago_utm.tif", "rasterio_RGBA.uint16.tif", "rasterio_world.byte.tif"]


def copies(source, out, wanted=lambda label: True):
    """`source` written again in every format its bands allow that `wanted` names:
    (format, path, lossless)."""
    stem = os.path.join(out, os.path.splitext(os.path.basename(source))[0])
    with rasterio.open(source) as src:
        count, dtype, crs = src.count, src.dtypes[0], src.crs
    made = [("GeoTIFF", source, True)]

    def copy(label, path, driver, lossless=True, **options):
        if wanted(label):
            rasterio.shutil.copy(source, path, driver=driver, **options)
            made.append((label, path, lossless))

    if dtype in ("uint8", "uint16") and count in (1, 2, 3, 4):
        copy("PNG", stem + ".png", "PNG")
    if dtype == "uint8" and count in (1, 3):
        copy("JPEG q75", stem + ".jpg", "JPEG", False, QUALITY=75, WORLDFILE="YES")
    copy("BIL", stem + ".bil", "EHdr")
    if count == 1:
        if wanted("XYZ"):
            with open(stem + ".prj", "w") as f:
                f.write(crs.to_wkt(version=WktVersion.WKT1_ESRI))
        copy("XYZ", stem + ".xyz", "XYZ")
        copy("Surfer 7", stem + ".grd", "GS7BG")
        # SAGA: one band a grid, and its three files zipped as SAGA compresses them.
        copy("SAGA", stem + ".sdat", "SAGA")
        if wanted("SAGA compressed"):
            zipped = stem + "_zipped.sg-grd-z"
            rasterio.shutil.copy(source, stem + "_zipped.sdat", driver="SAGA")
            with zipfile.ZipFile(zipped, "w", zipfile.ZIP_DEFLATED) as archive:
                for extension in ("sgrd", "sdat", "prj"):
                    archive.write(stem + "_zipped." + extension,
                                  os.path.basename(stem) + "_zipped." + extension)
            made.append(("SAGA compressed", zipped, True))
    if dtype in ("uint8", "int16", "uint16", "int32", "uint32"):
        copy("JPEG 2000", stem + ".jp2", "JP2OpenJPEG", QUALITY=100, REVERSIBLE="YES")
    copy("ERDAS Imagine", stem + ".img", "HFA", COMPRESSED="YES")
    # Its own name: the Surfer copy is x.grd.
    copy("R raster", stem + "_r.grd", "RRASTER")
    # Its own name: an ENVI header is x.hdr, as the BIL's is.
    copy("ENVI", stem + "_envi.dat", "ENVI", INTERLEAVE="BIP")
    copy("netCDF-4", stem + ".nc", "netCDF", FORMAT="NC4", COMPRESS="DEFLATE")
    copy("ER Mapper", stem + ".ers", "ERS")
    # Zarr, as xarray writes a raster's bands (version 2: Blosc with LZ4; 3: Zstandard).
    for version in (2, 3):
        label = f"Zarr v{version}"
        if wanted(label):
            path = f"{stem}_v{version}.zarr"
            zarr_dataset(source).to_zarr(path, mode="w", zarr_format=version,
                                         consolidated=False)
            made.append((label, path, True))
    # GeoPackage: 8-bit imagery in PNG tiles (a fourth band is its alpha), one band of
    # any other type as a gridded coverage (float in TIFF tiles).
    if dtype == "uint8" or (count == 1 and dtype in ("int16", "uint16", "float32")):
        tiles = "TIFF" if dtype == "float32" else "PNG"
        copy("GeoPackage", stem + ".gpkg", "GPKG", TILE_FORMAT=tiles)
    return made


def zarr_dataset(source):
    """The raster at `source` as xarray holds one: its bands as one variable (band, y,
    x) or (y, x), cell-centre coordinates, the CRS as a grid mapping's WKT, its nodata
    as `_FillValue`."""
    import numpy as np
    import xarray as xr
    with rasterio.open(source) as src:
        values, transform, crs, nodata = src.read(), src.transform, src.crs, src.nodata
    x = transform.c + transform.a * (np.arange(values.shape[2]) + 0.5)
    y = transform.f + transform.e * (np.arange(values.shape[1]) + 0.5)
    dims = ("band", "y", "x") if len(values) > 1 else ("y", "x")
    data = values if len(values) > 1 else values[0]
    name = os.path.splitext(os.path.basename(source))[0]
    ds = xr.Dataset({name: (dims, data, {"grid_mapping": "spatial_ref"}),
                     "spatial_ref": xr.DataArray(0, attrs={"crs_wkt": crs.to_wkt()})},
                    coords={"x": x, "y": y})
    if nodata is not None:
        ds[name].encoding["_FillValue"] = nodata
    return ds


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
    named), the seed, the rasters (those of ../shared/data/raster unless named) and the
    formats (every one unless named; the GeoTIFF always), from the command line."""
    parser = argparse.ArgumentParser()
    parser.add_argument("binary")
    parser.add_argument("out")
    parser.add_argument("--teacher", action="append", default=[])
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--raster", action="append", default=[])
    parser.add_argument("--format", action="append", default=[])
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    return args, args.teacher or ["threshold", "texture"]


def main():
    args, teachers = arguments()
    print("| raster | format | bytes | mean ratio | pairs ≤ 1.03 | within 2 cells | "
          "same figures as the GeoTIFF |")
    print("|---|---|---|---|---|---|---|")
    for raster in args.raster or [os.path.join(DATA, name) for name in RASTERS]:
        name = os.path.basename(raster)
        source = os.path.join(args.out, name)
        shutil.copy(raster, source)
        reference = None
        wanted = (lambda label: label in args.format) if args.format else (lambda label: True)
        for label, path, _lossless in copies(source, args.out, wanted):
            results = run(args.binary, path, teachers, args.seed)
            figures = [(r["mean_cost_ratio"], r["within_radius"], r["max_cost_ratio"])
                       for r in results]
            reference = reference or figures
            mean = sum(f[0] for f in figures) / len(figures)
            within = sum(f[1] for f in figures) / len(figures)
            good = sum(f[0] <= 1.03 for f in figures)
            # An ER Mapper header's samples lie beside it.
            size = os.path.getsize(path) + (
                os.path.getsize(path[:-4]) if path.endswith(".ers") else 0)
            print(f"| {name} | {label} | {size:,} | {mean:.4f} | {good} of {len(figures)} | "
                  f"{within:.1%} | {'yes' if figures == reference else 'no'} |", flush=True)


if __name__ == "__main__":
    main()
