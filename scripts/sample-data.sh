#!/usr/bin/env bash
# Real rasters as R users have them: the example files of R's raster, terra, stars,
# rgdal and ncmeta packages (R-written .grd grids whose CRS is a PROJ string,
# GeoTIFFs of a Landsat scene and DEMs, netCDF files of climate and ocean products,
# the GeoTIFF project's State Plane samples, an ENVI classification, a VRT over a raw
# file), from Debian's
# packages of them, and xarray-spatial's Sentinel-2 bands, from its wheel, into
# target/sample-data/<package>/. The test that reads them skips where they cannot be
# fetched; a package a Debian release lacks is left out, and the test with it.
# And the TIFFs Rust's TIFF crates test themselves on (the `geotiff` and `async-tiff`
# crates from crates.io: a Swiss DEM, user-defined Mercator, tie-point and
# PixelIsPoint variants, CMYK, min-is-white, old-style LZW, half floats, BigTIFF in
# either byte order...), into target/crate-tiffs/.
set -euo pipefail
cd "$(dirname "$0")/.."
crate_tiffs=target/crate-tiffs
if [ ! -f "$crate_tiffs/.complete" ]; then
    rm -rf "$crate_tiffs"
    mkdir -p "$crate_tiffs"
    if python3 - "$crate_tiffs" <<'PY'; then touch "$crate_tiffs/.complete"; fi
import io, os, sys, tarfile, urllib.request
into = sys.argv[1]
# Each crate's TIFFs: its version and the folders that hold them.
crates = {"geotiff": ("0.1.0", ["resources/"]),
          "async-tiff": ("0.4.0", ["fixtures/image-tiff/", "fixtures/other/"])}
try:
    for name, (version, folders) in crates.items():
        url = f"https://static.crates.io/crates/{name}/{name}-{version}.crate"
        with urllib.request.urlopen(url, timeout=60) as response:
            archive = tarfile.open(fileobj=io.BytesIO(response.read()), mode="r:gz")
        prefix = f"{name}-{version}/"
        for member in archive.getmembers():
            path = member.name[len(prefix):]
            if (member.isfile() and path.lower().endswith((".tif", ".tiff"))
                    and any(path.startswith(folder) for folder in folders)):
                with open(os.path.join(into, os.path.basename(path)), "wb") as f:
                    f.write(archive.extractfile(member).read())
except OSError as error:
    print(f"sample-data: could not fetch the TIFF crates' test files ({error}); the "
          "test that reads them will skip", file=sys.stderr)
    sys.exit(1)
PY
fi
out=target/sample-data
[ -f "$out/.complete" ] && exit 0
if ! command -v apt-get >/dev/null || ! command -v dpkg-deb >/dev/null; then
    echo "sample-data: no apt-get and dpkg-deb to fetch R's sample rasters; the tests" \
        "that read them will skip" >&2
    exit 0
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
packages=(r-cran-raster r-cran-terra r-cran-stars r-cran-rgdal r-cran-ncmeta)
fetch() { (cd "$work" && apt-get download -qq "$1" 2>/dev/null); }
fetch "${packages[0]}" || apt-get update -qq 2>/dev/null || true
for package in "${packages[@]}"; do
    fetch "$package" || echo "sample-data: apt could not fetch $package; its files are" \
        "left out" >&2
done
if ! compgen -G "$work/*.deb" >/dev/null; then
    echo "sample-data: apt fetched none of ${packages[*]}; the test that reads R's sample" \
        "rasters will skip" >&2
    exit 0
fi
for deb in "$work"/*.deb; do dpkg-deb -x "$deb" "$work/tree"; done
library="$work/tree/usr/lib/R/site-library"
rm -rf "$out"
# Copies the files of `from` matching the patterns into `$out/<to>`.
take() {
    local to=$1 from=$2
    shift 2
    mkdir -p "$out/$to"
    [ -d "$library/$from" ] || return 0
    for pattern in "$@"; do
        find "$library/$from" -maxdepth 1 -type f -name "$pattern" -exec cp {} "$out/$to/" \;
    done
}
take raster raster/external '*.grd' '*.gri'
take terra terra/ex '*.tif' '*.grd' '*.gri'
take stars stars/tif '*.tif'
take stars stars/nc '*.nc'
take ncmeta ncmeta/extdata 'S2008001.L3m_*.nc'
take rgdal rgdal/pictures '*.TIF' '*.tif' '*.asc' '*.envi' '*.hdr' '*.vrt' '*.dat'
# xarray-spatial's Sentinel-2 bands: netCDF as legacy xarray wrote it (the CRS a `crs`
# attribute, an attribute name in Latin-1).
if python3 -m pip download --no-deps -q -d "$work/wheels" xarray-spatial==0.5.3 2>/dev/null; then
    python3 - "$work"/wheels/xarray_spatial-*.whl "$out/xrspatial" <<'PY'
import sys, zipfile, os
wheel, into = sys.argv[1], sys.argv[2]
os.makedirs(into, exist_ok=True)
with zipfile.ZipFile(wheel) as z:
    for member in z.namelist():
        if member.startswith("xrspatial/datasets/sentinel-2/") and member.endswith(".nc"):
            with open(os.path.join(into, os.path.basename(member)), "wb") as f:
                f.write(z.read(member))
PY
else
    echo "sample-data: pip could not fetch xarray-spatial's wheel; its bands are left out" >&2
fi
touch "$out/.complete"
