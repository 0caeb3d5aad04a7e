"""ER Mapper rasters (`.ers` header beside the raw samples) as GDAL's ERS driver writes
them (through rasterio) and as ER Mapper writes them, each beside a GeoTIFF twin of
what GDAL reads it to. Prints one JSON line:

- `pairs` (GeoTIFF twin, header): GDAL-written rasters of each CRS family ER Mapper
  names (a 2-band int16 image on UTM south with band names and nodata, GDA94's and
  GDA2020's MGA zones, NAD83's UTM, degrees on WGS 84) and of CRSs it has no name for
  (`EPSG:3035`, New Zealand's 2193), of every sample type; and a header as ER Mapper
  writes it (big-endian samples, longitude and latitude as d:m:s registered at the
  centre of the top-left cell, a `DataFile` of another name, a header offset);
- `gda94_degrees`: degrees on GDA94, which GDAL reads with no CRS;
- `refused`: rasters refused, by what is wrong: a rotation, a projection ER Mapper
  names that is not read here, the samples missing.
"""

import json
import os
import sys

import numpy as np
import rasterio
import rasterio.crs
from rasterio.transform import from_origin

from gdal_twin import twin, write_bands

out = sys.argv[1]
rng = np.random.default_rng(12)
field = rng.normal(size=(2, 60, 80)).cumsum(1).cumsum(2)


def path_of(name):
    return os.path.join(out, name)


def write(name, values, crs, transform, names=None, **options):
    return write_bands(path_of(name), "ERS", values, crs, transform, names, **options)


utm = from_origin(400020.0, 6200010.0, 25, 25)
image = (field * 5 + 100).astype("int16")
image[:, 20:25, 30:40] = -9999
written = [
    write("image.ers", image, "EPSG:32755", utm, ("red", "nir"), nodata=-9999),
    write("mga94.ers", (field[:1] * 3 + 500).astype("float32"), "EPSG:28355", utm),
    write("mga2020.ers", (np.abs(field[:1]) * 40).astype("uint16"), "EPSG:7856", utm),
    write("nad83.ers", (np.abs(field[:1]) % 7).astype("uint8"), "EPSG:26915",
          from_origin(500000.0, 5000000.0, 30, 30)),
    write("degrees.ers", field[1:] * 0.01 + 12.5, "EPSG:4326",
          from_origin(150.5, -33.2, 1 / 1200, 1 / 1200)),
    write("laea.ers", (field[:1] * 4e5).astype("int32"), "EPSG:3035",
          from_origin(4_000_000.0, 3_000_000.0, 100, 100)),
    write("nztm.ers", (np.abs(field[:1]) * 4e5).astype("uint32"), "EPSG:2193",
          from_origin(1_500_000.0, 5_200_000.0, 10, 10)),
]
gda94_degrees = write("gda94.ers", (field[:1] * 3).astype("float32"), "EPSG:4283",
                      from_origin(150.5, -33.2, 1 / 1200, 1 / 1200))

# As ER Mapper writes a grid: big-endian samples after a header offset, in a file named
# by DataFile, registered in degrees at the centre of the top-left cell.
heights = (field[0] * 3 + 1500).astype(">i2")
heights[5:9, 5:9] = -32768
with open(path_of("dem_samples.bin"), "wb") as f:
    f.write(b"\0" * 512)
    f.write(heights.tobytes())
ermapper = path_of("ermapper.ers")
with open(ermapper, "w") as f:
    f.write('DatasetHeader Begin\n\tVersion\t\t= "7.0"\n\tLastUpdated\t= Mon Mar 01 '
            '10:00:00 GMT 2021\n\tDataFile\t= "dem_samples.bin"\n\tHeaderOffset\t= 512\n'
            '\tDataSetType\t= ERStorage\n'
            '\tDataType\t= Raster\n\tByteOrder\t= MSBFirst\n\tCoordinateSpace Begin\n'
            '\t\tDatum\t\t= "WGS84"\n\t\tProjection\t= "GEODETIC"\n'
            '\t\tCoordinateType\t= LATLONG\n\t\tRotation\t= 0:0:0.0\n'
            '\tCoordinateSpace End\n\tRasterInfo Begin\n\t\tCellType\t= Signed16BitInteger\n'
            '\t\tNullCellValue\t= -32768\n\t\tCellInfo Begin\n\t\t\tXdimension\t= 0.00025\n'
            '\t\t\tYdimension\t= 0.00025\n\t\tCellInfo End\n\t\tNrOfLines\t= 60\n'
            '\t\tNrOfCellsPerLine\t= 80\n'
            '\t\tRegistrationCellX\t= 0.5\n\t\tRegistrationCellY\t= 0.5\n'
            '\t\tRegistrationCoord Begin\n\t\t\tLongitude\t= 149:7:30.0\n'
            '\t\t\tLatitude\t= -35:18:00.0\n\t\tRegistrationCoord End\n'
            '\t\tNrOfBands\t= 1\n\t\tBandId Begin\n\t\t\tValue\t\t= "elevation"\n'
            '\t\tBandId End\n\tRasterInfo End\nDatasetHeader End\n')
written.append(ermapper)


def variant(name, old, new, samples=True):
    """A copy of the GDAL-written MGA raster as `name`, its header's `old` made `new`."""
    text = open(path_of("mga94.ers")).read()
    assert old in text, old
    open(path_of(name), "w").write(text.replace(old, new))
    if samples:
        open(path_of(name[:-4]), "wb").write(open(path_of("mga94"), "rb").read())
    return path_of(name)


refused = {
    "rotated": variant("rotated.ers", "Rotation\t= 0:0:0.0", "Rotation\t= 30:0:0.0"),
    "projection": variant("tmamg.ers", '"MGA55"', '"TMAMG"'),
    "headless": variant("no_samples.ers", "mga94", "no_samples", samples=False),
}

def twin_by_code(path):
    """GDAL's twin of `path`, its CRS by the EPSG code GDAL identifies it as (GDAL reads
    ER Mapper's names to a WKT with no authority, and would write its parameters)."""
    pair = twin(path)
    with rasterio.open(path) as src:
        code = src.crs.to_epsg() if src.crs else None
    if code:
        with rasterio.open(pair[0], "r+") as dst:
            dst.crs = rasterio.crs.CRS.from_epsg(code)
    return pair


print(json.dumps({
    "pairs": [twin_by_code(path) for path in written],
    "gda94_degrees": gda94_degrees,
    "refused": refused,
}))
