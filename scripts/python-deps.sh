#!/usr/bin/env bash
# Installs the Python packages the tests use to write files with the real tools
# (rasterio, whose wheels carry GDAL; pyarrow, pandas and polars for Parquet) into
# target/python-deps, where the tests look.
set -euo pipefail
cd "$(dirname "$0")/.."
deps=target/python-deps
if PYTHONPATH=$deps python3 -c 'import rasterio, numpy, pyarrow, pandas, polars' 2>/dev/null; then
    exit 0
fi
python3 -m pip install --quiet --disable-pip-version-check --upgrade --target "$deps" \
    'rasterio>=1.4,<2' 'numpy>=1.26' 'pyarrow>=15' 'pandas>=2' 'polars>=1'
