#!/usr/bin/env bash
# The test command: the Python packages some tests write files with, the browser the
# report test opens the HTML report in, R's example rasters some tests read, our own
# Python package, then every test.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/python-deps.sh
scripts/browser-deps.sh
scripts/sample-data.sh
scripts/python-package.sh
cargo test --locked "$@"
