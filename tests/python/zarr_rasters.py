"""Zarr stores as xarray writes them (`Dataset.to_zarr`, zarr-python 3), each beside a
GeoTIFF twin of what they read to. Prints one JSON line:

- `pairs` (twin, store): version 2 stores, twinned by GDAL's reading (its Zarr driver
  through rasterio): an int16 DEM in UTM with `_FillValue` and rioxarray's grid mapping
  (`spatial_ref` with `crs_wkt`), in chunks that leave partial chunks at the edges and
  one chunk never written (all fill), compressed as zarr writes version 2 by default
  (Blosc with LZ4 and byte shuffle), with Blosc's Zstandard, zlib and BloscLZ, Blosc
  with bit shuffle, with Zstandard, zlib and gzip alone, uncompressed, and with `/` between
  chunk indices, and a store
  GDAL's Zarr driver writes (X and Y arrays, the CRS in `_CRS`); version 3
  stores (which this GDAL does not read), twinned by xarray's own reading: the same
  DEM with zarr's default Zstandard, with gzip and a CRC-32C checksum, with Blosc; a
  float32 field in degrees, latitudes from the south, no grid mapping (also in Blosc
  with Zstandard and bit shuffle); a 3-band uint16
  image (band, y, x) beside a second variable on the grid; the DEM in shards of 2 × 2
  chunks;
- `refused`: stores refused, by what is wrong: no coordinates.
"""

import json
import os
import sys
import warnings

import numpy as np
import rasterio
import rasterio.shutil
import xarray as xr
import zarr
from numcodecs import Blosc, GZip, Zlib, Zstd
from rasterio.transform import from_origin
from zarr.codecs import BloscCodec, Crc32cCodec, GzipCodec

warnings.filterwarnings("ignore")

out = sys.argv[1]
rng = np.random.default_rng(11)
field = rng.normal(size=(3, 50, 70)).cumsum(1).cumsum(2)
UTM = rasterio.crs.CRS.from_epsg(32632)


def path_of(name):
    return os.path.join(out, name)


def dem_dataset():
    """The int16 DEM on a UTM grid, voids as -9999, one corner chunk all voids."""
    values = (field[0] * 3 + 1500).astype("int16")
    values[20:26, 30:41] = -9999
    values[:16, :20] = -9999
    x = 400015.0 + 30 * np.arange(70)
    y = 5200015.0 - 30 * np.arange(50)
    spatial_ref = xr.DataArray(0, attrs={"crs_wkt": UTM.to_wkt(),
                                         "spatial_ref": UTM.to_wkt()})
    ds = xr.Dataset({"elevation": (("y", "x"), values, {"grid_mapping": "spatial_ref"}),
                     "spatial_ref": spatial_ref},
                    coords={"x": ("x", x, {"units": "metre"}),
                            "y": ("y", y, {"units": "metre"})})
    ds["elevation"].encoding.update({"_FillValue": -9999, "chunks": (16, 20)})
    return ds


def repeating_dataset():
    """An int16 grid of 200 × 300 in one chunk whose rows repeat every 40 (24,000 bytes
    back, past BloscLZ's one-byte distances), with a run of zeros and a void."""
    values = np.tile((field[1, :40, :60].repeat(5, axis=1) * 7).astype("int16"), (5, 1))
    values[60:70] = 0
    values[100:104, 10:20] = -9999
    ds = dem_dataset().isel(x=[0], y=[0]).drop_vars("elevation")
    x = 400015.0 + 30 * np.arange(300)
    y = 5200015.0 - 30 * np.arange(200)
    ds = xr.Dataset({"elevation": (("y", "x"), values, {"grid_mapping": "spatial_ref"}),
                     "spatial_ref": ds["spatial_ref"]},
                    coords={"x": ("x", x, {"units": "metre"}),
                            "y": ("y", y, {"units": "metre"})})
    ds["elevation"].encoding.update({"_FillValue": -9999, "chunks": (200, 300)})
    return ds


def write(name, ds, version, **encoding):
    """`ds` written as store `name` in Zarr `version`, its gridded variables encoded as
    `encoding` says (`compressor`: version 2's one compressor, None for none)."""
    path = path_of(name)
    if "compressor" in encoding:
        compressor = encoding.pop("compressor")
        encoding["compressors"] = [compressor] if compressor else None
    if encoding:
        for variable in ds.data_vars:
            if ds[variable].ndim >= 2:
                ds[variable].encoding.update(encoding)
    ds.to_zarr(path, mode="w", zarr_format=version, consolidated=False)
    return path


def gdal_twin(store, variables):
    """Writes `store`.tif, GDAL's reading of `variables` of the store, its bands named
    as imitate names its layers; returns [twin, store]."""
    bands, names = [], []
    for variable in variables:
        with rasterio.open(f'ZARR:"{store}":/{variable}') as src:
            values = src.read().astype("float32")
            values[src.read_masks() == 0] = np.nan
            transform, crs = src.transform, src.crs
        bands.extend(values)
        names.extend([variable] * len(values))
    return write_twin(store, np.stack(bands), names, transform, crs)


def xarray_twin(store, crs):
    """Writes `store`.tif, xarray's reading (masked and scaled) of every gridded
    variable; returns [twin, store]."""
    ds = xr.open_zarr(store, consolidated=False)
    bands, names = [], []
    for variable in sorted(ds.data_vars):
        array = ds[variable]
        if array.ndim < 2:
            continue
        values = array.values.astype("float32")
        if array.ndim == 2:
            bands.append(values)
            names.append(variable)
        else:
            leading = array.dims[0]
            for i, plane in enumerate(values):
                bands.append(plane)
                names.append(f"{variable}_{leading}{i}")
        x, y = array[array.dims[-1]].values, array[array.dims[-2]].values
    dx, dy = (x[-1] - x[0]) / (len(x) - 1), (y[-1] - y[0]) / (len(y) - 1)
    stacked = np.stack(bands)
    if dy > 0:
        stacked = stacked[:, ::-1]
        top = y[-1] + dy / 2
    else:
        top = y[0] - dy / 2
    transform = from_origin(x[0] - dx / 2, top, dx, abs(dy))
    return write_twin(store, stacked, names, transform, crs)


def write_twin(store, stacked, names, transform, crs):
    with rasterio.open(store + ".tif", "w", driver="GTiff", width=stacked.shape[2],
                       height=stacked.shape[1], count=len(stacked), dtype="float32",
                       transform=transform, crs=crs, nodata=float("nan")) as dst:
        dst.write(stacked)
        dst.descriptions = names
    return [store + ".tif", store]


pairs = []
# Version 2: zarr's default compressor, Blosc's others, the plain codecs, none.
for name, encoding in [
    ("v2_default.zarr", {}),
    ("v2_blosc_zstd.zarr", {"compressor": Blosc(cname="zstd", clevel=3, shuffle=Blosc.SHUFFLE)}),
    ("v2_blosc_zlib.zarr", {"compressor": Blosc(cname="zlib", clevel=5, shuffle=Blosc.NOSHUFFLE)}),
    ("v2_zstd.zarr", {"compressor": Zstd(level=3)}),
    ("v2_zlib.zarr", {"compressor": Zlib(level=6)}),
    ("v2_gzip.zarr", {"compressor": GZip(level=6)}),
    ("v2_raw.zarr", {"compressor": None}),
    ("v2_bitshuffle.zarr", {"compressor": Blosc(cname="lz4", shuffle=Blosc.BITSHUFFLE)}),
    ("v2_blosclz.zarr", {"compressor": Blosc(cname="blosclz", clevel=9, shuffle=Blosc.SHUFFLE)}),
    ("v2_blosclz_noshuffle.zarr", {"compressor": Blosc(cname="blosclz", clevel=1,
                                                        shuffle=Blosc.NOSHUFFLE)}),
]:
    pairs.append(gdal_twin(write(name, dem_dataset(), 2, **encoding), ["elevation"]))
slashed = path_of("v2_slashed.zarr")
dem_dataset().to_zarr(slashed, mode="w", zarr_format=2, consolidated=False)
# The same chunks with `/` between their indices, as zarr's NestedDirectoryStore did.
array = zarr.open_array(os.path.join(slashed, "elevation"), mode="r")
meta = json.load(open(os.path.join(slashed, "elevation", ".zarray")))
for key in sorted(os.listdir(os.path.join(slashed, "elevation"))):
    if key[0].isdigit():
        row, column = key.split(".")
        os.makedirs(os.path.join(slashed, "elevation", row), exist_ok=True)
        os.rename(os.path.join(slashed, "elevation", key),
                  os.path.join(slashed, "elevation", row, column))
meta["dimension_separator"] = "/"
json.dump(meta, open(os.path.join(slashed, "elevation", ".zarray"), "w"))
pairs.append(gdal_twin(slashed, ["elevation"]))
for name, shuffle in [("v2_blosclz_far.zarr", Blosc.NOSHUFFLE),
                      ("v2_blosclz_far_shuffled.zarr", Blosc.SHUFFLE)]:
    compressor = Blosc(cname="blosclz", clevel=9, shuffle=shuffle, blocksize=1 << 17)
    pairs.append(gdal_twin(write(name, repeating_dataset(), 2, compressor=compressor),
                           ["elevation"]))

# As GDAL's Zarr driver writes a raster (gdal_translate -of Zarr): X and Y arrays, the
# CRS in the array's _CRS attribute.
with rasterio.open(path_of("dem_source.tif"), "w", driver="GTiff", width=70, height=50,
                   count=1, dtype="int16", crs=UTM, nodata=-9999,
                   transform=from_origin(400000.0, 5200030.0, 30, 30)) as dst:
    dst.write(dem_dataset()["elevation"].values, 1)
gdal_written = path_of("gdal_written.zarr")
rasterio.shutil.copy(path_of("dem_source.tif"), gdal_written, driver="Zarr")
pairs.append(gdal_twin(gdal_written, ["gdal_written"]))

# Version 3: zarr's default Zstandard, gzip with a checksum, Blosc.
pairs.append(xarray_twin(write("v3_default.zarr", dem_dataset(), 3), UTM))
pairs.append(xarray_twin(write("v3_gzip.zarr", dem_dataset(), 3,
                               compressors=[GzipCodec(level=5), Crc32cCodec()]), UTM))
pairs.append(xarray_twin(write("v3_blosc.zarr", dem_dataset(), 3,
                               compressors=[BloscCodec(cname="lz4", shuffle="shuffle")]), UTM))

# Degrees, latitudes from the south, NaN voids, no grid mapping.
lat = 46.0 + (np.arange(50) + 0.5) / 120
lon = 7.0 + (np.arange(70) + 0.5) / 120
temperature = (field[1] * 0.1 + 10).astype("float32")
temperature[5:9, 5:9] = np.nan
degrees = xr.Dataset({"temperature": (("lat", "lon"), temperature)},
                     coords={"lat": ("lat", lat, {"units": "degrees_north"}),
                             "lon": ("lon", lon, {"units": "degrees_east"})})
pairs.append(xarray_twin(write("v3_degrees.zarr", degrees, 3), "EPSG:4326"))
pairs.append(xarray_twin(write("v3_degrees_bitshuffle.zarr", degrees, 3, compressors=[
    BloscCodec(cname="zstd", shuffle="bitshuffle")]), "EPSG:4326"))

# Bands first, and a second variable on the grid.
image = (np.abs(field) * 50).astype("uint16")
bands = dem_dataset()
bands["image"] = (("band", "y", "x"), image, {"grid_mapping": "spatial_ref"})
bands = bands.assign_coords(band=[1, 2, 3])
pairs.append(xarray_twin(write("v3_bands.zarr", bands, 3), UTM))

# Sharded: shards of 2 × 2 chunks, one shard's chunks partly never written.
pairs.append(xarray_twin(write("v3_sharded.zarr", dem_dataset(), 3,
                               chunks=(8, 10), shards=(16, 20)), UTM))

# Refused: an array with no coordinates.
bare = path_of("bare.zarr")
xr.Dataset({"elevation": (("y", "x"), field[0])}).to_zarr(bare, mode="w", zarr_format=3,
                                                          consolidated=False)
print(json.dumps({"pairs": pairs, "refused": {"bare": bare}}))
