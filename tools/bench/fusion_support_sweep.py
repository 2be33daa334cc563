#!/usr/bin/python3
"""Support sweep of multi-sensor fusion (BENCHMARKS "Multi-sensor fusion, round 5").

The same extraction rule is applied to the fused cloud and to each single sensor (like for like):
for every W, `edgefuse fuse RIGSET --sensors S --min-support W` (both voxels of a zero crossing
hold at least W weight units) and, separately, `--min-support 0 --min-weight W` (the largest weight
of the 8 voxels around the point is at least W); all other options at their defaults, same
--origin. Each cloud is scored as in fusion_bench.py: median / 95th percentile distance to the true
meshes and coverage of the visible true surface within 2 mm; "only-xtion-less" counts the points
more than 2 mm from the xtion-alone cloud of the same rule (the other sensors' own surface).
Since round 5b a mixed set's sub-unit samples fill a voxel only to 3 units (fusion_rules.hpp rule 3);
`--extra "--sub-unit-fill 8"` gives round 5's table.

  /usr/bin/python3 tools/bench/fusion_support_sweep.py [--rig ../shared/data/bin_rig_a]
        [--edgefuse build/host/tools/edgefuse] [--support 0,1,2,3,4,6,8,9,12,16,24,32]
        [--sensors xtion;xtion,tof,laser;xtion,laser;tof] [--min-weight 0,4,8,16,32]
"""
import argparse
import os
import sys

import numpy as np
import open3d as o3d

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from fusion_bench import add_rig_arguments, run, truth  # noqa: E402


def fuse(ef, rig, sensors, opts, origin, path):
    run([ef, "fuse", rig, "--sensors", sensors, "--origin", origin, "--out", path] + opts)
    return o3d.io.read_point_cloud(path)


def main():
    ap = argparse.ArgumentParser()
    add_rig_arguments(ap, "fusion_sweep")
    ap.add_argument("--support", default="0,1,2,3,4,5,6,8,9,12,16,24,32")
    ap.add_argument("--min-weight", default="0,4,8,9,16,32")
    ap.add_argument("--sensors", default="xtion;xtion,tof,laser;xtion,laser;tof")
    ap.add_argument("--extra", default="", help="extra fuse options for every run (space separated)")
    a = ap.parse_args()
    os.makedirs(a.workdir, exist_ok=True)
    mesh, scene, vis, vis_pc = truth(a.rig)
    extra = a.extra.split()
    sensors = a.sensors.split(";")
    rules = [("min-support %s" % w, ["--min-support", w]) for w in a.support.split(",")]
    rules += [("min-weight %s" % w, ["--min-support", "0", "--min-weight", w]) for w in a.min_weight.split(",")
              if w != "0"]
    print()
    print("| rule | sensors | points | median (mm) | 95th pct (mm) | coverage (%) | points > 2 mm from xtion (same rule) | of those > 2 mm off the truth |")
    print("|---|---|---|---|---|---|---|---|")
    for rule, opts in rules:
        xtion_pc = None
        for s in sensors:
            path = os.path.join(a.workdir, "%s_%s.ply" % (s.replace(",", "_"), rule.replace(" ", "")))
            pc = fuse(a.edgefuse, a.rig, s, opts + extra, a.origin, path)
            p = np.asarray(pc.points, dtype=np.float32)
            if s == "xtion":
                xtion_pc = pc
            if len(p) == 0:
                print("| %s | %s | 0 | | | | | |" % (rule, s))
                continue
            d = scene.compute_distance(o3d.core.Tensor(p)).numpy()
            cov = float(np.mean(np.asarray(vis_pc.compute_point_cloud_distance(pc)) <= 0.002))
            extra_cols = "| |"
            if xtion_pc is not None and s != "xtion":
                far = np.asarray(pc.compute_point_cloud_distance(xtion_pc)) > 0.002
                extra_cols = "| %d | %d |" % (far.sum(), (far & (d > 0.002)).sum())
            print("| %s | %s | %d | %.4f | %.3f | %.1f %s" % (rule, s, len(p), 1e3 * np.median(d),
                                                             1e3 * np.percentile(d, 95), 100 * cov, extra_cols),
                  flush=True)


if __name__ == "__main__":
    main()
