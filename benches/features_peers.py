#!/usr/bin/env python3
"""Feature operators: imitate against the same operators in NumPy/SciPy (scipy.ndimage),
same map, same machine, side by side in one run.

imitate writes its synthetic map (4 layers) and the feature spec with `imitate bench
features --dump DIR`; this script computes every feature of that spec with NumPy/SciPy,
times it, and checks that each feature's mean agrees with imitate's. Run from the
repository root after `cargo build --release`:

    python3 benches/features_peers.py [--size 4096] [--repeat 3]
"""

import argparse
import json
import os
import subprocess
import tempfile
import time

import numpy as np
from scipy import ndimage


def compute(layers, spec, res, width, height):
    """Every feature of the spec, in imitate's order and naming."""
    out = {}
    for name in spec["layers"]:
        out[name] = layers[name].copy()
    cap_default = float(np.hypot(width * res, height * res))
    for op in spec["ops"]:
        kind = op["op"]
        x = layers.get(op.get("layer"))
        def num(v):
            return f"{v:g}"
        if kind == "blur":
            for s in op["sigmas"]:
                out[f"{op['layer']}/blur_{num(s)}m"] = ndimage.gaussian_filter(x, s / res, mode="reflect", truncate=4.0)
        elif kind in ("gradient", "slope"):
            gy, gx = np.gradient(x.astype(np.float64), res)
            mag = np.hypot(gx, gy)
            if kind == "gradient":
                out[f"{op['layer']}/gradient"] = mag.astype(np.float32)
            else:
                out[f"{op['layer']}/slope_deg"] = np.degrees(np.arctan(mag)).astype(np.float32)
        elif kind == "roughness":
            x64 = x.astype(np.float64)
            for w in op["windows"]:
                m = ndimage.uniform_filter(x64, w, mode="reflect")
                m2 = ndimage.uniform_filter(x64 * x64, w, mode="reflect")
                out[f"{op['layer']}/roughness_{w}c"] = np.sqrt(np.maximum(m2 - m * m, 0)).astype(np.float32)
        elif kind == "laplacian":
            out[f"{op['layer']}/laplacian"] = (ndimage.laplace(x.astype(np.float64), mode="reflect") / res**2).astype(np.float32)
        elif kind == "normalize":
            q25, q50, q75 = np.percentile(x, [25, 50, 75], method="lower")
            rng = q75 - q25 if q75 > q25 else 1.0
            out[f"{op['layer']}/robust"] = (x - q50) / rng
        elif kind == "threshold":
            for t in op["above"]:
                out[f"{op['layer']}/above_{num(t)}"] = (x > t).astype(np.float32)
        elif kind == "one_hot":
            for c in op["classes"]:
                out[f"{op['layer']}/class_{num(c)}"] = (x == c).astype(np.float32)
        elif kind == "distance":
            if op.get("class") is not None:
                mask, label = x == op["class"], f"class_{num(op['class'])}"
            else:
                mask, label = x > op["above"], f"above_{num(op['above'])}"
            cap = op.get("max") or cap_default
            if mask.any():
                d = ndimage.distance_transform_edt(~mask) * res
            else:
                d = np.full(x.shape, cap)
            out[f"{op['layer']}/distance_to_{label}_m"] = np.minimum(d, cap).astype(np.float32)
        elif kind == "product":
            out[f"{op['a']}*{op['b']}"] = out[op["a"]] * out[op["b"]]
        else:
            raise SystemExit(f"unknown operator {kind}")
    if spec["bias"]:
        out["bias"] = np.ones((height, width), np.float32)
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=4096)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--imitate", default="target/release/imitate")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        ours = json.loads(subprocess.run(
            [args.imitate, "bench", "features", "--size", str(args.size), "--repeat", str(args.repeat),
             "--dump", tmp, "--json"], check=True, capture_output=True, text=True).stdout)
        meta = json.load(open(os.path.join(tmp, "spec.json")))
        w, h, res = meta["width"], meta["height"], meta["resolution"]
        layers = {name: np.fromfile(os.path.join(tmp, f"{name}.f32"), dtype="<f4").reshape(h, w)
                  for name in ["elevation", "vegetation", "water", "road"]}
    times, result = [], None
    for _ in range(args.repeat):
        start = time.perf_counter()
        result = compute(layers, meta["spec"], res, w, h)
        times.append(time.perf_counter() - start)
    t_peer = min(times)
    worst = 0.0
    for f in ours["features"]:
        theirs = float(np.mean(result[f["name"]], dtype=np.float64))
        diff = abs(theirs - f["mean"]) / max(abs(theirs), 1e-6)
        worst = max(worst, diff)
        if diff > 1e-3:
            print(f"  mean of {f['name']} differs: imitate {f['mean']:.6g}, NumPy/SciPy {theirs:.6g}")
    print(f"features {args.size}x{args.size}, {len(ours['features'])} features, best of {args.repeat}:")
    print(f"  imitate ({ours['threads']} threads): {ours['best_seconds']:.3f} s, "
          f"peak extra memory {ours['peak_over_output']:.2f}x the output stack ({ours['output_bytes'] / 2**20:.0f} MiB)")
    print(f"  NumPy/SciPy (one thread): {t_peer:.3f} s")
    print(f"  ratio: {t_peer / ours['best_seconds']:.1f}x; largest relative difference of feature means: {worst:.1e}")


if __name__ == "__main__":
    main()
