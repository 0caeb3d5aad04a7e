"""Runs an ONNX model with onnxruntime, as a robot's own stack would, after checking it
with `onnx.checker` (full check, shape inference included).

usage: onnx_run.py MODEL.onnx OBSERVATIONS.json
OBSERVATIONS.json holds a list of observation rows; prints one JSON line per row with
the model's `action` row.
"""

import json
import sys

import numpy as np
import onnx
import onnxruntime

model = onnx.load(sys.argv[1])
onnx.checker.check_model(model, full_check=True)
rows = np.asarray(json.load(open(sys.argv[2])), dtype=np.float32)
session = onnxruntime.InferenceSession(sys.argv[1], providers=["CPUExecutionProvider"])
(action,) = session.run(["action"], {"observation": rows})
for row in action:
    print(json.dumps([float(v) for v in row]))
