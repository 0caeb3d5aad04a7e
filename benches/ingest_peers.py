#!/usr/bin/env python3
"""Robot-log ingest: imitate against Foxglove's Python readers (`mcap` + `mcap-ros2-support`)
decoding the same MCAP file on the same machine, side by side in one run.

imitate writes the log (100 Hz nav_msgs/Odometry, 10 Hz 512x512 nav_msgs/OccupancyGrid,
zstd chunks, >= 200 MB) with `imitate bench ingest FILE --generate`, then times its own
decode + ingest of it (best of --repeat). The peer decodes every message of the same file
with `make_reader(...).iter_decoded_messages()` and the ROS 2 decoder factory, and turns
the grids into NumPy arrays and the poses into tuples: the least a Python ingest does.
Run from the repository root after `cargo build --release`:

    pip install mcap mcap-ros2-support numpy
    python3 benches/ingest_peers.py [--megabytes 200] [--repeat 3]
"""

import argparse
import json
import os
import resource
import subprocess
import tempfile
import time

import numpy as np
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

IMITATE = os.path.join(os.path.dirname(__file__), "..", "target", "release", "imitate")


def python_ingest(path):
    """Decode every message; keep the last grid as an array and every pose."""
    grid, poses, messages = None, [], 0
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _schema, channel, _message, decoded in reader.iter_decoded_messages():
            messages += 1
            if channel.topic == "/map":
                info = decoded.info
                grid = np.asarray(decoded.data, dtype=np.int8).reshape(info.height, info.width)
            elif channel.topic == "/odom":
                p = decoded.pose.pose
                poses.append((p.position.x, p.position.y, p.orientation.z, p.orientation.w))
    return messages, len(poses), grid.size


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--megabytes", type=int, default=200)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--file", help="reuse this log instead of a temporary one")
    args = parser.parse_args()

    with tempfile.TemporaryDirectory() as tmp:
        path = args.file or os.path.join(tmp, "bench.mcap")
        if not os.path.exists(path):
            subprocess.run([IMITATE, "bench", "ingest", path, "--generate",
                            "--megabytes", str(args.megabytes)], check=True)
        def imitate(threads):
            env = dict(os.environ)
            if threads:
                env["RAYON_NUM_THREADS"] = str(threads)
            return json.loads(subprocess.run(
                [IMITATE, "bench", "ingest", path, "--repeat", str(args.repeat), "--json"],
                check=True, capture_output=True, text=True, env=env).stdout)

        ours = imitate(None)
        one_thread = imitate(1)

        before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
        start = time.perf_counter()
        messages, poses, cells = python_ingest(path)
        theirs = time.perf_counter() - start
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024

    assert messages == ours["messages"], (messages, ours["messages"])
    assert poses == ours["poses"], (poses, ours["poses"])
    assert cells == ours["grid_cells"], (cells, ours["grid_cells"])
    mb = ours["file_bytes"] / 1e6
    print(f"file: {mb:.1f} MB, {ours['messages']} messages, {ours['chunks']} chunks "
          f"(largest {ours['largest_chunk_bytes'] / 1e6:.1f} MB uncompressed)")
    print(f"imitate, all threads ({os.cpu_count()}): {ours['seconds']:8.3f} s  "
          f"{ours['megabytes_per_second']:7.0f} MB/s  "
          f"peak extra memory {ours['peak_extra_bytes'] / 1e6:.1f} MB")
    print(f"imitate, 1 thread:   {one_thread['seconds']:8.3f} s  "
          f"{one_thread['megabytes_per_second']:7.0f} MB/s  "
          f"peak extra memory {one_thread['peak_extra_bytes'] / 1e6:.1f} MB")
    print(f"python mcap+ros2:    {theirs:8.3f} s  {mb / theirs:7.1f} MB/s  "
          f"peak memory growth {(peak - before) / 1e6:.1f} MB")
    print(f"ratio (python / imitate, all threads): {theirs / ours['seconds']:.1f}x; "
          f"1 thread: {theirs / one_thread['seconds']:.1f}x")


if __name__ == "__main__":
    main()
