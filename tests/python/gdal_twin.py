"""The GeoTIFF twin of what GDAL reads a raster to, for the tests that hold imitate's
readers to GDAL's: float32 bands, NaN where GDAL's mask says no data, the grid, CRS,
band descriptions, units, scales and offsets carried over."""

import imagecodecs
import numpy as np
import rasterio


def write_bands(path, driver, values, crs, transform, names=None, **options):
    """Writes `values` (bands, rows, columns) with GDAL's `driver` at `path`, its bands
    described by `names` where given; returns `path`."""
    with rasterio.open(path, "w", driver=driver, width=values.shape[2],
                       height=values.shape[1], count=values.shape[0], dtype=values.dtype,
                       crs=crs, transform=transform, **options) as dst:
        dst.write(values)
        if names:
            dst.descriptions = names
    return path


def twin(path, to=None):
    """Writes `to` (by default `path`.tif), GDAL's reading of `path`; returns [twin,
    path]."""
    to = to or path + ".tif"
    with rasterio.open(path) as src:
        values = src.read().astype("float32")
        values[src.read_masks() == 0] = np.nan
        profile = dict(driver="GTiff", width=src.width, height=src.height, count=src.count,
                       dtype="float32", transform=src.transform, nodata=float("nan"))
        if src.crs:
            profile["crs"] = src.crs
        with rasterio.open(to, "w", **profile) as dst:
            dst.write(values)
            dst.descriptions = src.descriptions
            dst.units = src.units
            dst.scales = src.scales
            dst.offsets = src.offsets
    return [to, path]


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


def lossy_tiles_difference(path, placed):
    """How far libjpeg-turbo's and libwebp's decoding (imagecodecs) of a tiled raster's
    lossy tiles is from GDAL's reading of `path`: the largest and mean difference over
    the colour bands, the yardstick for another decoder's. `placed` gives each tile's
    top row and left column in GDAL's grid (either may be negative) and its bytes."""
    with rasterio.open(path) as src:
        gdal = src.read().astype(float).transpose(1, 2, 0)
        valid = src.dataset_mask() > 0
    differences = []
    for top, left, data in placed:
        if data[:2] == b"\xff\xd8":
            tile = imagecodecs.jpeg8_decode(data)
        elif data[:4] == b"RIFF":
            tile = imagecodecs.webp_decode(data)
        else:
            continue
        tile = tile.astype(float)
        if tile.ndim == 2:
            tile = tile[:, :, None]
        bands = min(tile.shape[2], gdal.shape[2], 3)
        ys = slice(max(top, 0), max(min(top + tile.shape[0], gdal.shape[0]), 0))
        xs = slice(max(left, 0), max(min(left + tile.shape[1], gdal.shape[1]), 0))
        theirs = gdal[ys, xs, :bands]
        mine = tile[ys.start - top:ys.stop - top, xs.start - left:xs.stop - left, :bands]
        differences.append(np.abs(mine - theirs)[valid[ys, xs]].ravel())
    difference = np.concatenate(differences) if differences else np.zeros(0)
    assert difference.size, f"{path} holds no lossy tile"
    return [float(difference.max()), float(difference.mean())]
