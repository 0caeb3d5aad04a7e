"""For each pair of GeoTIFFs (a source and what imitate wrote back from it), whether
rasterio (GDAL) reads the same CRS, and both files' bounds and cell sizes in that CRS:
one JSON line per pair."""

import json
import sys

import rasterio

files = sys.argv[1:]
for source, written in zip(files[::2], files[1::2]):
    with rasterio.open(source) as a, rasterio.open(written) as b:
        print(json.dumps({
            "source": source,
            "same_crs": a.crs == b.crs,
            "crs": a.crs.to_string(),
            "written_crs": b.crs.to_string() if b.crs else None,
            "bounds": list(a.bounds),
            "written_bounds": list(b.bounds),
            "res": list(a.res),
            "written_res": list(b.res),
        }))
