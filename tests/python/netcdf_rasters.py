"""netCDF rasters as the tools people use write them, each beside a GeoTIFF twin of what
GDAL's netCDF driver reads it to (float32, NaN where GDAL's mask says no data, every
gridded variable's bands in the file's order, named by their variable):

- GDAL (rasterio's netCDF driver): an int16 UTM DEM with nodata in classic netCDF and
  in netCDF-4 with Deflate, a 3-band float32 image in degrees (three variables), a
  uint8 cover in classic netCDF (`_Unsigned`, `valid_range`);
- netCDF4-python, as GEBCO hands out bathymetry: latitudes running north from the
  south, int16 heights with no fill value, no grid mapping;
- netCDF4-python, as ERA5 is handed out: latitudes from the north in single precision,
  a time dimension of three steps, int16 packed by `scale_factor`/`add_offset` with a
  `_FillValue` and a `missing_value`, and a float32 variable beside it with NaN voids;
- xarray with a `spatial_ref` grid mapping holding `crs_wkt` (rioxarray's form): UTM
  heights in kilometres and a land cover with CF `flag_values`, through the netCDF
  library and through h5py (the h5netcdf engine, chunked and compressed);
- netCDF4-python with CF grid-mapping parameters and no WKT: an Antarctic polar
  stereographic grid (NSIDC's, BedMachine's) and a Lambert conformal grid on a sphere
  (WRF's);
- netCDF4-python as NOAA's ETOPO comes with Ferret (`.cdf`, a global grid whose nodes
  lie on the poles), as CAMS regions come (0–360° longitudes cut across Greenwich) and
  as Daymet comes (a Lambert grid in km).

Also, by hand: the same grid with longitudes running west and east, with its
coordinates packed as int32 micro-degrees, lying (lat, lon) and (lon, lat), and named
`.nc` and `.h5` (read alike), and files a reader must refuse: uneven latitudes, no gridded variable, an Esri
ASCII grid named `.grd`, a rotated-pole grid mapping with no WKT. Prints one JSON line."""

import json
import os
import sys

import netCDF4
import numpy as np
import rasterio
import rasterio.shutil
import xarray as xr
from rasterio.transform import from_origin

out = sys.argv[1]
rng = np.random.default_rng(5)
field = rng.normal(size=(4, 60, 80)).cumsum(1).cumsum(2)


def path_of(name):
    return os.path.join(out, name)


def gdal_written(name, values, crs, transform, nodata=None, **options):
    """`name` written by GDAL's netCDF driver (a create-copy driver) from a GeoTIFF."""
    tif = path_of(name + ".source.tif")
    with rasterio.open(tif, "w", driver="GTiff", width=values.shape[2],
                       height=values.shape[1], count=values.shape[0], dtype=values.dtype,
                       crs=crs, transform=transform, nodata=nodata) as dst:
        dst.write(values)
    rasterio.shutil.copy(tif, path_of(name), driver="netCDF", **options)
    os.remove(tif)
    return path_of(name)


utm = from_origin(440000, 4640000, 30, 30)
dem = (field[0] * 3 + 200).astype("int16")
dem[20:30, 10:30] = -9999
cover = (np.abs(field[1]) * 5 % 250).astype("uint8")
files = [
    gdal_written("dem_classic.nc", dem[None], "EPSG:32616", utm, nodata=-9999, FORMAT="NC"),
    gdal_written("dem_deflate.nc", dem[None], "EPSG:32616", utm, nodata=-9999, FORMAT="NC4",
                 COMPRESS="DEFLATE"),
    gdal_written("image_degrees.nc", (field[:3] * 0.25).astype("float32"), "EPSG:4326",
                 from_origin(-100.0, 40.0, 1 / 120, 1 / 120), FORMAT="NC4"),
    gdal_written("cover_classic.nc", cover[None], "EPSG:32616", utm, FORMAT="NC"),
]

# As GEBCO: latitudes from the south, no fill value, no grid mapping.
gebco = path_of("gebco_like.nc")
with netCDF4.Dataset(gebco, "w", format="NETCDF4") as ds:
    ds.Conventions = "CF-1.6"
    ds.createDimension("lat", 60)
    ds.createDimension("lon", 80)
    lat = ds.createVariable("lat", "f8", ("lat",))
    lat[:] = -45 + (np.arange(60) + 0.5) / 240
    lat.standard_name, lat.units = "latitude", "degrees_north"
    lon = ds.createVariable("lon", "f8", ("lon",))
    lon[:] = 170 + (np.arange(80) + 0.5) / 240
    lon.standard_name, lon.units = "longitude", "degrees_east"
    elevation = ds.createVariable("elevation", "i2", ("lat", "lon"), fill_value=False,
                                  zlib=True)
    elevation.units = "m"
    elevation[:] = (field[2] * 20 - 300).astype("int16")
files.append(gebco)

# As NOAA's ETOPO comes with Ferret (`.cdf`, classic netCDF): a global grid whose nodes
# lie on the grid lines, the poles among them (its cells reach half a cell past them).
etopo = path_of("etopo_like.cdf")
with netCDF4.Dataset(etopo, "w", format="NETCDF3_CLASSIC") as ds:
    ds.createDimension("ETOPO60Y", 91)
    ds.createDimension("ETOPO60X", 180)
    lat = ds.createVariable("ETOPO60Y", "f8", ("ETOPO60Y",))
    lat[:] = np.linspace(-90, 90, 91)
    lat.units = "degrees_north"
    lon = ds.createVariable("ETOPO60X", "f8", ("ETOPO60X",))
    lon[:] = 20 + 2 * np.arange(180)
    lon.units, lon.modulo = "degrees_east", " "
    rose = ds.createVariable("ROSE", "f4", ("ETOPO60Y", "ETOPO60X"))
    rose.units = "METERS"
    rose[:] = np.resize(field[0] * 300, (91, 180))
files.append(etopo)

# As CAMS and ERA5 regions cut across Greenwich from 0–360° longitudes.
across = path_of("across_greenwich.nc")
with netCDF4.Dataset(across, "w", format="NETCDF4") as ds:
    ds.createDimension("latitude", 11)
    ds.createDimension("longitude", 11)
    lat = ds.createVariable("latitude", "f4", ("latitude",))
    lat[:] = 50.95 - 0.1 * np.arange(11)
    lat.units = "degrees_north"
    lon = ds.createVariable("longitude", "f4", ("longitude",))
    lon[:] = (359.55 + 0.1 * np.arange(11)) % 360
    lon.units = "degrees_east"
    pm10 = ds.createVariable("pm10_conc", "f4", ("latitude", "longitude"))
    pm10[:] = np.abs(field[1, :11, :11])
files.append(across)

# As Daymet: a Lambert conformal grid whose x and y count in km.
daymet = path_of("daymet_like.nc")
with netCDF4.Dataset(daymet, "w", format="NETCDF4") as ds:
    ds.createDimension("y", 60)
    ds.createDimension("x", 80)
    for axis, values in (("x", -778.25 + np.arange(80)), ("y", -120.0 - np.arange(60))):
        v = ds.createVariable(axis, "f4", (axis,))
        v[:] = values
        v.units, v.standard_name = "km", f"projection_{axis}_coordinate"
    crs = ds.createVariable("lambert_conformal_conic", "i2", ())
    crs.grid_mapping_name = "lambert_conformal_conic"
    crs.longitude_of_central_meridian, crs.latitude_of_projection_origin = -100.0, 42.5
    crs.standard_parallel = [25.0, 60.0]
    crs.false_easting, crs.false_northing = 0.0, 0.0
    crs.semi_major_axis, crs.inverse_flattening = 6378137.0, 298.257223563
    prcp = ds.createVariable("prcp", "f4", ("y", "x"), fill_value=-9999.0)
    prcp.grid_mapping = "lambert_conformal_conic"
    prcp[:] = np.abs(field[2]) * 3
files.append(daymet)

# As ERA5: latitudes from the north in single precision, time steps, packed integers.
era5 = path_of("era5_like.nc")
with netCDF4.Dataset(era5, "w", format="NETCDF4") as ds:
    ds.createDimension("time", None)
    ds.createDimension("latitude", 60)
    ds.createDimension("longitude", 80)
    time = ds.createVariable("time", "i4", ("time",))
    time.units = "hours since 1900-01-01 00:00:00.0"
    time[:] = [1000, 1001, 1002]
    lat = ds.createVariable("latitude", "f4", ("latitude",))
    lat[:] = 60 - np.arange(60) * 0.25
    lat.units = "degrees_north"
    lon = ds.createVariable("longitude", "f4", ("longitude",))
    lon[:] = -10 + np.arange(80) * 0.25
    lon.units = "degrees_east"
    t2m = ds.createVariable("t2m", "i2", ("time", "latitude", "longitude"),
                            fill_value=-32767)
    t2m.set_auto_maskandscale(False)
    t2m.scale_factor, t2m.add_offset = 0.0015, 275.0
    t2m.missing_value = np.int16(-32767)
    t2m.units = "K"
    packed = np.stack([(field[3] + i) * 300 for i in range(3)]).clip(-32000, 32000)
    packed = packed.astype("int16")
    packed[1, 5:9, 5:9] = -32767
    t2m[:] = packed
    sp = ds.createVariable("sp", "f4", ("time", "latitude", "longitude"),
                           fill_value=np.float32(np.nan))
    sp.units = "Pa"
    pressure = np.stack([field[0] * 10 + 101000 + i for i in range(3)]).astype("float32")
    pressure[2, 40:, :5] = np.nan
    sp[:] = pressure
files.append(era5)

# As xarray with rioxarray's grid mapping: UTM, heights in kilometres, a cover's flags.
x = 500015.0 + 30 * np.arange(80)
y = 7200015.0 - 30 * np.arange(60)
wkt = rasterio.crs.CRS.from_epsg(32633).to_wkt()
heights = xr.DataArray((field[1] * 0.01 + 1.2).astype("float32"), dims=("y", "x"),
                       attrs={"units": "km", "grid_mapping": "spatial_ref"})
classes = xr.DataArray((np.abs(field[2]) % 4).astype("uint8"), dims=("y", "x"),
                       attrs={"flag_values": np.array([0, 1, 2, 3], "uint8"),
                              "flag_meanings": "water forest grass rock",
                              "grid_mapping": "spatial_ref"})
dataset = xr.Dataset(
    {"height": heights, "land_cover": classes},
    coords={"x": ("x", x, {"standard_name": "projection_x_coordinate", "units": "m"}),
            "y": ("y", y, {"standard_name": "projection_y_coordinate", "units": "m"}),
            "spatial_ref": ((), 0, {"crs_wkt": wkt, "spatial_ref": wkt})})
xarray_utm = path_of("xarray_utm.nc")
dataset.to_netcdf(xarray_utm, encoding={"land_cover": {"_FillValue": None}})
files.append(xarray_utm)

# The same through h5py rather than the netCDF library (xarray's h5netcdf engine),
# chunked and compressed.
h5netcdf_utm = path_of("h5netcdf_utm.nc")
dataset.to_netcdf(h5netcdf_utm, engine="h5netcdf", encoding={
    "land_cover": {"_FillValue": None},
    "height": {"zlib": True, "complevel": 4, "chunksizes": (16, 32)}})
files.append(h5netcdf_utm)
# The same named .h5, as h5netcdf users name their files.
h5_named = path_of("h5netcdf_utm.h5")
dataset.to_netcdf(h5_named, engine="h5netcdf", encoding={
    "land_cover": {"_FillValue": None},
    "height": {"zlib": True, "complevel": 4, "chunksizes": (16, 32)}})


def cf_projected(name, mapping):
    """A grid in metres whose CRS only CF's grid-mapping parameters give (no WKT), as
    NSIDC's polar grids and WRF's Lambert grids come."""
    with netCDF4.Dataset(path_of(name), "w", format="NETCDF4") as ds:
        ds.createDimension("y", 60)
        ds.createDimension("x", 80)
        ds.createVariable("x", "f8", ("x",))[:] = -1_200_000 + 5000 * (np.arange(80) + 0.5)
        ds["x"].standard_name = "projection_x_coordinate"
        ds.createVariable("y", "f8", ("y",))[:] = 900_000 - 5000 * (np.arange(60) + 0.5)
        ds["y"].standard_name = "projection_y_coordinate"
        crs = ds.createVariable("crs", "i4", ())
        for key, value in mapping.items():
            setattr(crs, key, value)
        thickness = ds.createVariable("thickness", "f4", ("y", "x"), fill_value=-9999.0)
        thickness.grid_mapping = "crs"
        thickness.units = "m"
        thickness[:] = np.abs(field[3]) * 40
    return path_of(name)


files.append(cf_projected("polar_cf.nc", {
    "grid_mapping_name": "polar_stereographic", "straight_vertical_longitude_from_pole": 0.0,
    "latitude_of_projection_origin": -90.0, "standard_parallel": -71.0, "false_easting": 0.0,
    "false_northing": 0.0, "semi_major_axis": 6378137.0, "inverse_flattening": 298.257223563}))
files.append(cf_projected("lambert_cf.nc", {
    "grid_mapping_name": "lambert_conformal_conic", "standard_parallel": [30.0, 60.0],
    "longitude_of_central_meridian": -98.0, "latitude_of_projection_origin": 38.0,
    "false_easting": 0.0, "false_northing": 0.0, "earth_radius": 6370000.0}))


def twin(path):
    """Writes `path`.tif, GDAL's reading of every gridded variable of `path`, its bands
    named by their variable (and time step); returns [twin, path]."""
    with rasterio.open(path) as top:
        sources = top.subdatasets or [path]
    bands, names, scales, offsets, units = [], [], [], [], []
    for source in sources:
        with rasterio.open(source) as src:
            values = src.read().astype("float32")
            values[src.read_masks() == 0] = np.nan
            tags = src.tags(1)
            variable = tags["NETCDF_VARNAME"]
            numbered = tags.get("long_name", "").startswith("GDAL Band Number")
            extra = src.tags().get("NETCDF_DIM_EXTRA", "{}").strip("{}")
            for band in range(src.count):
                bands.append(values[band])
                name = None if numbered else variable
                if name and extra:
                    name += f"_{extra}{band}"
                names.append(name)
            scales += src.scales
            offsets += src.offsets
            units += src.units
            transform, crs = src.transform, src.crs or "EPSG:4326"
    stacked = np.stack(bands)
    with rasterio.open(path + ".tif", "w", driver="GTiff", width=stacked.shape[2],
                       height=stacked.shape[1], count=len(bands), dtype="float32",
                       transform=transform, crs=crs, nodata=float("nan")) as dst:
        dst.write(stacked)
        dst.descriptions = names
        dst.units = units
        dst.scales = scales
        dst.offsets = offsets
    return [path + ".tif", path]


pairs = [twin(f) for f in files]

# Longitudes running west, beside the same grid running east.
east, west = path_of("east.nc"), path_of("west.nc")
for path, order in [(east, 1), (west, -1)]:
    with netCDF4.Dataset(path, "w", format="NETCDF3_CLASSIC") as ds:
        ds.createDimension("lat", 60)
        ds.createDimension("lon", 80)
        ds.createVariable("lat", "f8", ("lat",))[:] = 10 + (np.arange(60) + 0.5) / 100
        ds["lat"].units = "degrees_north"
        ds.createVariable("lon", "f8", ("lon",))[:] = (20 + (np.arange(80) + 0.5) / 100)[::order]
        ds["lon"].units = "degrees_east"
        ds.createVariable("z", "f4", ("lat", "lon"))[:] = field[0][:, ::order]

# The eastward grid again with its coordinates packed: int32 micro-degrees.
packed = path_of("packed.nc")
with netCDF4.Dataset(packed, "w", format="NETCDF4") as ds:
    for name, values in [("lat", 10 + (np.arange(60) + 0.5) / 100),
                         ("lon", 20 + (np.arange(80) + 0.5) / 100)]:
        ds.createDimension(name, len(values))
        coordinate = ds.createVariable(name, "i4", (name,))
        coordinate.set_auto_maskandscale(False)
        coordinate.scale_factor = 1e-6
        coordinate.units = "degrees_north" if name == "lat" else "degrees_east"
        coordinate[:] = np.round(values * 1e6).astype("int32")
    ds.createVariable("z", "f4", ("lat", "lon"))[:] = field[0]


def lat_lon_file(name, lat_values, dims=("lat", "lon"), mapping=None):
    with netCDF4.Dataset(path_of(name), "w", format="NETCDF4") as ds:
        ds.createDimension("lat", len(lat_values))
        ds.createDimension("lon", 80)
        ds.createVariable("lat", "f8", ("lat",))[:] = lat_values
        ds["lat"].units = "degrees_north"
        ds.createVariable("lon", "f8", ("lon",))[:] = np.arange(80) * 0.5
        ds["lon"].units = "degrees_east"
        z = ds.createVariable("z", "f4", dims)
        z[:] = field[0][: len(lat_values)] if dims[0] == "lat" else field[0].T
        if mapping:
            ds.createVariable("crs", "i4", ())
            ds["crs"].grid_mapping_name = mapping
            z.grid_mapping = "crs"
    return path_of(name)


# The same grid stored (lat, lon) and (lon, lat), as NASA's TRMM subsets lie.
lat_lon = lat_lon_file("lat_lon.nc", np.arange(60) * 0.5)
lon_lat = lat_lon_file("lon_lat.nc", np.arange(60) * 0.5, dims=("lon", "lat"))
refused = {
    "uneven": lat_lon_file("uneven.nc", np.sin(np.linspace(-1.2, 1.2, 60)) * 80),
    "no_wkt": lat_lon_file("no_wkt.nc", np.arange(60) * 0.5, mapping="rotated_latitude_pole"),
}
with netCDF4.Dataset(path_of("points.nc"), "w", format="NETCDF4") as ds:
    ds.createDimension("station", 5)
    ds.createVariable("height", "f4", ("station",))[:] = np.arange(5)
refused["points"] = path_of("points.nc")
with open(path_of("ascii_grid.grd"), "w") as f:
    f.write("ncols 2\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 1\n1 2\n3 4\n")
refused["neither"] = path_of("ascii_grid.grd")

print(json.dumps({"pairs": pairs, "east": east, "west": west, "packed": packed,
                  "lat_lon": lat_lon, "lon_lat": lon_lat, "h5": h5_named,
                  "h5_twin": h5netcdf_utm,
                  "refused": refused,
                  "classes": [xarray_utm, h5netcdf_utm]}))
