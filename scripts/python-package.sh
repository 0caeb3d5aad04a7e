#!/usr/bin/env bash
# Builds the Python package `imitate` (PyO3, with maturin) and installs it into
# target/python-package, where the tests look. The dev profile shares the test build's
# compiled dependencies, so this adds the bindings and one link, not a second build of
# the crate; `pip install .` makes the optimised package for use.
set -euo pipefail
cd "$(dirname "$0")/.."
tools=target/python-tools
if [ ! -x "$tools/bin/maturin" ]; then
    python3 -m pip install --quiet --disable-pip-version-check --target "$tools" \
        'maturin>=1.5,<2'
fi
rm -rf target/python-wheel
"$tools/bin/maturin" build --quiet --locked --profile dev --compatibility linux \
    --out target/python-wheel
python3 -m pip install --quiet --disable-pip-version-check --root-user-action=ignore --no-deps --upgrade \
    --target target/python-package target/python-wheel/imitate-*.whl
