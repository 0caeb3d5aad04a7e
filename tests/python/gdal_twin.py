"""The GeoTIFF twin of what GDAL reads a raster to, for the tests that hold imitate's
readers to GDAL's: float32 bands, NaN where GDAL's mask says no data, the grid, CRS,
band descriptions, units, scales and offsets carried over."""

import numpy as np
import rasterio


def twin(path):
    """Writes `path`.tif, GDAL's reading of `path`; returns [twin, path]."""
    with rasterio.open(path) as src:
        values = src.read().astype("float32")
        values[src.read_masks() == 0] = np.nan
        profile = dict(driver="GTiff", width=src.width, height=src.height, count=src.count,
                       dtype="float32", transform=src.transform, nodata=float("nan"))
        if src.crs:
            profile["crs"] = src.crs
        with rasterio.open(path + ".tif", "w", **profile) as dst:
            dst.write(values)
            dst.descriptions = src.descriptions
            dst.units = src.units
            dst.scales = src.scales
            dst.offsets = src.offsets
    return [path + ".tif", path]


def imagery_twin(path, bands):
    """Writes `path`.tif, GDAL's reading of imagery shown with an alpha band (GeoPackage,
    MBTiles): its first `bands` colour bands, NaN where GDAL's mask (alpha) is 0;
    returns [twin, path]."""
    with rasterio.open(path) as src:
        colours = src.read(list(range(1, bands + 1))).astype("float32")
        colours[:, src.dataset_mask() == 0] = np.nan
        with rasterio.open(path + ".tif", "w", driver="GTiff", width=src.width,
                           height=src.height, count=bands, dtype="float32",
                           crs=src.crs, transform=src.transform,
                           nodata=float("nan")) as dst:
            dst.write(colours)
    return [path + ".tif", path]
