"""Reading the formats a GeoTIFF may come as instead: 8192² files (UTM, 30 m) written by
GDAL: ERDAS Imagine (its HFA driver) with an int16 DEM in raw blocks, a 9-class uint8
cover in raw blocks and the same cover run-length compressed; netCDF (its netCDF
driver) with the DEM in classic netCDF and in netCDF-4 with Deflate; GeoPackage (its
GPKG driver) with the DEM as a gridded coverage and the cover as imagery, both in
256² PNG tiles; MBTiles (its MBTiles driver) with the cover in PNG tiles, on zoom level
16's Web Mercator grid (so that GDAL writes its cells as they are), and that package as
a PMTiles archive (Protomaps' converter; GDAL, which reads no raster PMTiles, is timed
on the package); SAGA (its SAGA driver) with the DEM as a grid, and zipped as SAGA's
compressed grid (`.sg-grd-z`, Deflate); ER Mapper (its ERS driver) with the DEM; Zarr (xarray's `to_zarr`) with the DEM in 512²
chunks, version 2 (Blosc with LZ4, with BloscLZ, with LZ4 bit-shuffled) and 3
(Zstandard); each beside an
uncompressed GeoTIFF twin of the same values. Times `imitate plan` on each (it reads
the raster as costs and plans two cells apart: the read is the time; wall and user CPU
seconds, the VM's page faults making the wall time noisy) and, in this process, GDAL reading the band through rasterio
(`read(1)`). Each time the best of three (by wall time), the files written and synced
first.

    PYTHONPATH=target/python-deps python3 benches/format_read.py \\
        target/release/imitate target/format_read [LABEL PART]

(a third argument runs only the files whose label holds it: `MBTiles`, say).

Prints a Markdown table: file, bytes, imitate on the file, imitate on the GeoTIFF twin,
GDAL's read of the file, and the ratio of imitate's file to its GeoTIFF.
"""

import math
import os
import resource
import subprocess
import sys
import time
import zipfile

import numpy as np
import rasterio
import rasterio.shutil
from numcodecs import Blosc
from pmtiles.convert import mbtiles_to_pmtiles
from rasterio.transform import from_origin

SIZE = 8192
#: Each time is the best of this many runs, the files in the page cache.
REPEATS = 3


#: Web Mercator cells of zoom level 16 (256-cell tiles), and a tile corner near
#: Chicago: an MBTiles package of a raster on this grid holds its cells unresampled.
ZOOM_16_CELL = 2 * 6378137.0 * math.pi / 256 / 2**16
ZOOM_16_CORNER = (-6378137.0 * math.pi + 16800 * 256 * ZOOM_16_CELL,
                  6378137.0 * math.pi - 24300 * 256 * ZOOM_16_CELL)


def write(path, values, driver, mercator=False, **options):
    """`values` written to `path` by GDAL's `driver` (a create-copy driver from a
    GeoTIFF): in UTM, 30 m cells, or (`mercator`) on zoom level 16's Web Mercator grid."""
    if driver == "PMTiles":
        source = write(path + ".mbtiles", values, "MBTiles", mercator, **options)
        mbtiles_to_pmtiles(source, path, None)
        return path
    if driver.startswith("Zarr"):
        import xarray as xr
        crs = "EPSG:32616"
        x = 440000 + 30 * (np.arange(values.shape[1]) + 0.5)
        y = 4640000 - 30 * (np.arange(values.shape[0]) + 0.5)
        ref = xr.DataArray(0, attrs={"crs_wkt": rasterio.crs.CRS.from_string(crs).to_wkt()})
        ds = xr.Dataset({"dem": (("y", "x"), values, {"grid_mapping": "spatial_ref"}),
                         "spatial_ref": ref}, coords={"x": x, "y": y})
        ds["dem"].encoding["chunks"] = (512, 512)
        if "compressor" in options:
            ds["dem"].encoding["compressors"] = [options["compressor"]]
        ds.to_zarr(path, mode="w", zarr_format=int(driver[-1]), consolidated=False)
        return path
    if driver == "SAGA compressed":
        stem = os.path.splitext(path)[0]
        write(stem + ".sdat", values, "SAGA", mercator, **options)
        with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as archive:
            for extension in ("sgrd", "sdat", "prj"):
                archive.write(stem + "." + extension, os.path.basename(stem) + "." + extension)
        return path
    if driver in ("netCDF", "GPKG", "MBTiles"):
        source = write(path + ".source.tif", values, "GTiff", mercator)
        rasterio.shutil.copy(source, path, driver=driver, **options)
        os.remove(source)
        return path
    crs, transform = "EPSG:32616", from_origin(440000, 4640000, 30, 30)
    if mercator:
        crs, transform = "EPSG:3857", from_origin(*ZOOM_16_CORNER, ZOOM_16_CELL, ZOOM_16_CELL)
    with rasterio.open(path, "w", driver=driver, width=values.shape[1],
                       height=values.shape[0], count=1, dtype=values.dtype,
                       crs=crs, transform=transform, **options) as dst:
        dst.write(values, 1)
    return path


def size_of(path):
    """The bytes of a file (with its samples beside an ER Mapper header), or of every
    file in a folder (a Zarr store)."""
    if path.endswith(".ers"):
        return os.path.getsize(path) + os.path.getsize(path[:-4])
    if not os.path.isdir(path):
        return os.path.getsize(path)
    return sum(os.path.getsize(os.path.join(folder, name))
               for folder, _, names in os.walk(path) for name in names)


def timed_plan(binary, raster):
    """Wall seconds and user CPU seconds of one `imitate plan` on `raster`."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_utime
    start = time.perf_counter()
    run = subprocess.run([binary, "plan", raster, "--cells", "--start", "100,100",
                          "--goal", "102,103"], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    wall = time.perf_counter() - start
    return wall, resource.getrusage(resource.RUSAGE_CHILDREN).ru_utime - before


def timed_gdal(raster, values):
    start = time.perf_counter()
    with rasterio.open(raster) as src:
        read = src.read(1)
    elapsed = time.perf_counter() - start
    assert (read == values).all()
    return elapsed


def main():
    binary, out = sys.argv[1], sys.argv[2]
    only = sys.argv[3] if len(sys.argv) > 3 else ""
    os.makedirs(out, exist_ok=True)
    rng = np.random.default_rng(1)
    field = rng.normal(size=(SIZE, SIZE)).cumsum(0).cumsum(1)
    field /= np.abs(field).max()
    dem = (field * 15000 + 16000).astype("int16")
    cover = ((field * 30).round() % 9 + 1).astype("uint8")
    cases = [("Imagine: DEM, raw", "dem.img", dem, "HFA", {}),
             ("Imagine: cover, raw", "cover.img", cover, "HFA", {}),
             ("Imagine: cover, run-length", "cover_rle.img", cover, "HFA",
              {"COMPRESSED": "YES"}),
             ("netCDF classic: DEM", "dem.nc", dem, "netCDF", {"FORMAT": "NC"}),
             ("netCDF-4: DEM, Deflate", "dem_deflate.nc", dem, "netCDF",
              {"FORMAT": "NC4", "COMPRESS": "DEFLATE"}),
             ("GeoPackage: DEM, coverage in PNG tiles", "dem.gpkg", dem, "GPKG", {}),
             ("GeoPackage: cover, PNG tiles", "cover.gpkg", cover, "GPKG",
              {"TILE_FORMAT": "PNG"}),
             ("MBTiles: cover, PNG tiles", "cover.mbtiles", cover, "MBTiles", {}),
             ("PMTiles: cover, PNG tiles", "cover.pmtiles", cover, "PMTiles", {}),
             ("SAGA: DEM", "dem.sdat", dem, "SAGA", {}),
             ("SAGA: DEM, compressed (.sg-grd-z)", "dem_zipped.sg-grd-z", dem,
              "SAGA compressed", {}),
             ("ER Mapper: DEM", "dem.ers", dem, "ERS", {}),
             ("Zarr v2: DEM, Blosc LZ4, 512² chunks", "dem_v2.zarr", dem, "Zarr 2", {}),
             ("Zarr v2: DEM, Blosc BloscLZ, 512² chunks", "dem_v2_blosclz.zarr", dem,
              "Zarr 2", {"compressor": Blosc(cname="blosclz", shuffle=Blosc.SHUFFLE)}),
             ("Zarr v2: DEM, Blosc LZ4 bit-shuffled, 512² chunks", "dem_v2_bits.zarr", dem,
              "Zarr 2", {"compressor": Blosc(cname="lz4", shuffle=Blosc.BITSHUFFLE)}),
             ("Zarr v3: DEM, Zstandard, 512² chunks", "dem_v3.zarr", dem, "Zarr 3", {})]
    print("| file | bytes | imitate, the file: wall / user CPU | imitate, GeoTIFF twin | "
          "GDAL, the file | the file to GeoTIFF, user CPU |")
    print("|---|---|---|---|---|---|")
    for label, name, values, driver, options in cases:
        if only not in label:
            continue
        mercator = driver in ("MBTiles", "PMTiles")
        path = write(os.path.join(out, name), values, driver, mercator, **options)
        tif = write(os.path.join(out, name + ".tif"), values, "GTiff", mercator)
        os.sync()
        ours = min(timed_plan(binary, path) for _ in range(REPEATS))
        twin = min(timed_plan(binary, tif) for _ in range(REPEATS))
        # GDAL reads no raster PMTiles: it reads the MBTiles the archive was made from.
        gdal_reads = path + ".mbtiles" if driver == "PMTiles" else path
        # GDAL 3.10 reads no Zarr version 3 as zarr-python 3 writes it.
        gdal = ("–" if driver == "Zarr 3" else
                f"{min(timed_gdal(gdal_reads, values) for _ in range(REPEATS)):.2f} s")
        print(f"| {label} | {size_of(path):,} | {ours[0]:.2f} s / {ours[1]:.2f} s | "
              f"{twin[0]:.2f} s / {twin[1]:.2f} s | {gdal} | {ours[1] / twin[1]:.2f} |",
              flush=True)


if __name__ == "__main__":
    main()
