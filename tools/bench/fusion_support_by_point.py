#!/usr/bin/python3
"""Error of a fused cloud by its per-point evidence (BENCHMARKS "Multi-sensor fusion, round 5").

Reads the `support` property that `edgefuse fuse --sensors` writes into a binary PLY (the weight of
the weaker voxel of each point's zero crossing; weight units: 8 = one sample at the trust reference
noise), the distance of every point to the rig set's true meshes (as fusion_bench.py) and, when a
reference cloud is given (e.g. the xtion alone), which points lie more than 2 mm from it.

  /usr/bin/python3 tools/bench/fusion_support_by_point.py FUSED.ply [REFERENCE.ply]
        [--rig ../shared/data/bin_rig_a]
e.g. FUSED = `fuse --sensors xtion,tof,laser --full-coverage --origin -0.256,-0.256,-0.2`,
REFERENCE = `fuse --sensors xtion --origin -0.256,-0.256,-0.2`.
"""
import argparse
import os
import sys

import numpy as np
import open3d as o3d

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from fusion_bench import distance_scene, true_mesh  # noqa: E402


def read_ply_support(path):
    f = open(path, "rb")
    props, n, fmt = [], 0, ""
    while True:
        line = f.readline().decode().strip()
        if line.startswith("format"):
            fmt = line.split()[1]
        if line.startswith("element vertex"):
            n = int(line.split()[2])
        elif line.startswith("element"):
            sys.exit("%s: only a vertex element is read" % path)
        if line.startswith("property"):
            props.append((line.split()[2], line.split()[1]))
        if line == "end_header":
            break
    if fmt != "binary_little_endian":
        sys.exit("%s: binary_little_endian PLY expected" % path)
    tmap = {"float": "<f4", "uchar": "u1", "uint": "<u4", "int": "<i4"}
    dt = np.dtype([(nm, tmap[t]) for nm, t in props])
    a = np.frombuffer(f.read(n * dt.itemsize), dtype=dt, count=n)
    if "support" not in a.dtype.names:
        sys.exit("%s: no 'support' property (written by `edgefuse fuse --sensors`)" % path)
    return np.stack([a["x"], a["y"], a["z"]], 1).astype(np.float32), a["support"]


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    repo = os.path.dirname(os.path.dirname(here))
    ap = argparse.ArgumentParser()
    ap.add_argument("cloud")
    ap.add_argument("reference", nargs="?")
    ap.add_argument("--rig", default=os.path.join(repo, "..", "shared", "data", "bin_rig_a"))
    a = ap.parse_args()
    mesh = true_mesh(a.rig)
    scene = distance_scene(mesh)
    p, s = read_ply_support(a.cloud)
    d = scene.compute_distance(o3d.core.Tensor(p)).numpy() * 1e3
    far = np.zeros(len(p), dtype=bool)
    if a.reference:
        pc = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(p.astype(np.float64)))
        far = np.asarray(pc.compute_point_cloud_distance(o3d.io.read_point_cloud(a.reference))) > 0.002
    print("| support (weight units) | sigma_eff if unit-sized samples (mm) | points | median error (mm) | "
          "95th pct (mm) | of them > 2 mm from the reference | their median (mm) |")
    print("|---|---|---|---|---|---|---|")
    for lo, hi in [(1, 3), (4, 4), (5, 8), (9, 16), (17, 32), (33, 64), (65, 128), (129, 255)]:
        m = (s >= lo) & (s <= hi)
        if not m.any():
            continue
        print("| %d-%d | %.2f-%.2f | %d | %.3f | %.3f | %d | %.3f |" % (
            lo, hi, np.sqrt(8.0 / hi), np.sqrt(8.0 / lo), m.sum(), np.median(d[m]), np.percentile(d[m], 95),
            (m & far).sum(), np.median(d[m & far]) if (m & far).any() else 0.0))


if __name__ == "__main__":
    main()
