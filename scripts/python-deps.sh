#!/usr/bin/env bash
# Installs the Python packages the tests use to write and read files with the real tools
# (rasterio, whose wheels carry GDAL; tifffile with imagecodecs, for the JPEG XL GDAL's
# wheels leave out; pyarrow, pandas and polars for Parquet; Foxglove's mcap with its ROS
# 1 and ROS 2 support for logs; netCDF4, xarray and h5netcdf (with h5py) for netCDF grids
# as climate and ocean data are written; zarr for Zarr stores as xarray writes them;
# Protomaps' pmtiles for tile archives; gpxpy for
# GPS tracks; pyogrio (GDAL's OGR, as QGIS writes vectors) with shapely for GeoJSON
# paths; onnx and onnxruntime for exported policies; gymnasium for the DAgger loop with a
# simulator of someone else's; Ray for LEARCH on a cluster) into target/python-deps,
# where the tests look.
set -euo pipefail
cd "$(dirname "$0")/.."
deps=target/python-deps
if PYTHONPATH=$deps python3 -c \
    'import rasterio, tifffile, imagecodecs, numpy, pmtiles, pyarrow, pandas, polars, mcap, mcap_ros1, mcap_ros2, netCDF4, xarray, h5netcdf, h5py, zarr, gpxpy, pyogrio, shapely, onnx, onnxruntime, gymnasium, ray' \
    2>/dev/null; then
    exit 0
fi
python3 -m pip install --quiet --disable-pip-version-check --upgrade --target "$deps" \
    'rasterio>=1.4,<2' 'tifffile>=2024.1' 'imagecodecs>=2024.1' 'numpy>=1.26' 'pyarrow>=15' 'pandas>=2' 'polars>=1' \
    'mcap>=1.2,<2' 'mcap-ros1-support>=0.7,<1' 'mcap-ros2-support>=0.5,<1' 'gpxpy>=1.6,<2' \
    'pmtiles>=3.4,<4' 'netCDF4>=1.6,<2' 'xarray>=2024.1' 'h5netcdf>=1.3' 'h5py>=3.10' 'zarr>=3,<4' \
    'pyogrio>=0.7,<1' 'shapely>=2,<3' \
    'onnx>=1.14,<2' 'onnxruntime>=1.16,<2' 'gymnasium>=1.0,<2' 'ray>=2.9,<3'
