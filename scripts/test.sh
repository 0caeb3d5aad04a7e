#!/usr/bin/env bash
# The test command: the Python packages some tests write files with, then every test.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/python-deps.sh
cargo test --locked "$@"
