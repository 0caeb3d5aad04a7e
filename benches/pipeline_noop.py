#!/usr/bin/env python3
"""No-op pipeline runs: `imitate run` against DVC's `dvc repro` on same-shaped pipelines
(N stages, each reading the same two input files and writing its own output folder),
side by side in one run. Both are run once to populate, then timed when nothing changed.
Run from the repository root after `cargo build --release` (and `pip install dvc`):

    python3 benches/pipeline_noop.py [--stages 100 2] [--repeat 3]
"""

import argparse
import os
import shutil
import subprocess
import tempfile
import time


def best_of(repeat, cmd, cwd):
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        subprocess.run(cmd, cwd=cwd, check=True, capture_output=True)
        times.append(time.perf_counter() - start)
    return min(times)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stages", type=int, nargs="+", default=[100, 2])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--imitate", default="target/release/imitate")
    args = parser.parse_args()
    imitate = os.path.abspath(args.imitate)
    print(f"{'stages':>6} {'imitate no-op s':>16} {'dvc repro no-op s':>18} {'ratio':>7}")
    for n in args.stages:
        with tempfile.TemporaryDirectory() as tmp:
            ours, theirs = os.path.join(tmp, "imitate"), os.path.join(tmp, "dvc")
            os.makedirs(ours)
            subprocess.run([imitate, "testdata", "world", "--out", "world", "--maps", "1", "--width", "16",
                            "--height", "16", "--demonstrations-per-map", "1"], cwd=ours, check=True,
                           capture_output=True)
            # Inputs written a minute ago, like files in a repository: imitate's stat cache
            # trusts only files older than 2 s.
            past = time.time() - 60
            for root, _, files in os.walk(os.path.join(ours, "world")):
                for name in files:
                    os.utime(os.path.join(root, name), (past, past))
            shutil.copytree(os.path.join(ours, "world"), os.path.join(theirs, "world"))
            map_file, demos = "world/maps/terrain-000.parquet", "world/demonstrations.parquet"
            with open(os.path.join(ours, "p.yaml"), "w") as f:
                f.write("schema: 1\nstages:\n")
                for i in range(n):
                    f.write(f"  s{i}:\n    uses: ingest\n    with: {{maps: [{map_file}], "
                            f"demonstrations: {demos}, out: out/s{i}}}\n")
            with open(os.path.join(theirs, "dvc.yaml"), "w") as f:
                f.write("stages:\n")
                for i in range(n):
                    f.write(f"  s{i}:\n    cmd: mkdir -p out/s{i} && cp {map_file} {demos} out/s{i}/\n"
                            f"    deps: [{map_file}, {demos}]\n    outs: [out/s{i}]\n")
            subprocess.run(["dvc", "init", "--no-scm", "-q"], cwd=theirs, check=True)
            subprocess.run(["dvc", "config", "core.analytics", "false"], cwd=theirs, check=True)
            subprocess.run([imitate, "run", "p.yaml"], cwd=ours, check=True, capture_output=True)
            subprocess.run(["dvc", "repro", "-q"], cwd=theirs, check=True, capture_output=True)
            t_ours = best_of(args.repeat, [imitate, "run", "p.yaml"], ours)
            t_dvc = best_of(args.repeat, ["dvc", "repro", "-q"], theirs)
            print(f"{n:>6} {t_ours:>16.3f} {t_dvc:>18.3f} {t_dvc / t_ours:>6.0f}x")


if __name__ == "__main__":
    main()
