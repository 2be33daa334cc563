#!/usr/bin/python3
"""Where the fused cloud's error comes from, by category of true surface (issue 4, round 4).

Reads clouds written by `edgefuse fuse RIGSET --sensors ...` (e.g. by tools/bench/fusion_bench.py
into build/host/fusion_bench) and prints, for each cloud:
  * its points split into those within 2 mm of the xtion-alone cloud ("xtion's surface") and the
    others ("ToF-only" in a fusion of xtion, tof, laser), each by the true surface nearest to the
    point: floor, inner walls, outer walls (the bin's outer faces and bottom: not visible from
    above, so a point there is a crossing inside or behind the 10 mm wall material), rim, objects;
    count, median error and share > 2 mm off the true surface;
  * an oracle bound: the xtion+laser cloud plus only those ToF-only points of the cloud that lie
    within 0.5 / 1 / 2 mm of the true surface (a perfect filter): the best whole-cloud median any
    rule that keeps ToF-only surface could reach.

  /usr/bin/python3 tools/bench/fusion_categories.py --xtion X.ply --xtion-laser XL.ply CLOUD.ply...
        [--rig ../shared/data/bin_rig_a]
"""
import argparse
import os
import sys

import numpy as np
import open3d as o3d

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import fusion_bench as fb  # noqa: E402  (true_mesh: the bin plus the objects at their poses)


def categories(scene, mesh, n_bin_triangles, p):
    r = scene.compute_closest_points(o3d.core.Tensor(p.astype(np.float32)))
    tid = r["primitive_ids"].numpy()
    cp = r["points"].numpy()
    mesh.compute_triangle_normals()
    n = np.asarray(mesh.triangle_normals)[tid]
    c = np.full(len(p), "object", dtype=object)
    b = tid < n_bin_triangles
    # bin_rig_a's bin: inner floor z = 0, rim z = 0.12, inner faces |x| = 0.20 / |y| = 0.15, outer
    # faces |x| = 0.21 / |y| = 0.16 and the bottom z = -0.01 (README of the set).
    floor = b & (np.abs(n[:, 2]) > 0.9) & (np.abs(cp[:, 2]) < 0.001)
    rim = b & (np.abs(n[:, 2]) > 0.9) & (np.abs(cp[:, 2] - 0.12) < 0.0005)
    outer = b & ~floor & ~rim & ((np.abs(np.abs(cp[:, 0]) - 0.21) < 0.0005) | (np.abs(np.abs(cp[:, 1]) - 0.16) < 0.0005) |
                                 (np.abs(cp[:, 2] + 0.01) < 0.0005))
    c[floor] = "floor"
    c[rim] = "rim"
    c[outer] = "outer wall"
    c[b & ~floor & ~rim & ~outer] = "inner wall"
    return c


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    repo = os.path.dirname(os.path.dirname(here))
    ap = argparse.ArgumentParser()
    ap.add_argument("--rig", default=os.path.join(repo, "..", "shared", "data", "bin_rig_a"))
    ap.add_argument("--xtion", required=True, help="xtion-alone cloud")
    ap.add_argument("--xtion-laser", required=True, help="xtion+laser cloud (no ToF)")
    ap.add_argument("clouds", nargs="+")
    a = ap.parse_args()
    mesh = fb.true_mesh(a.rig)
    n_bin = len(o3d.io.read_triangle_mesh(os.path.join(a.rig, "models", "bin.ply")).triangles)
    scene = fb.distance_scene(mesh)

    def err(p):
        return scene.compute_distance(o3d.core.Tensor(p.astype(np.float32))).numpy()

    xt = o3d.io.read_point_cloud(a.xtion)
    xl = o3d.io.read_point_cloud(a.xtion_laser)
    d_xl = err(np.asarray(xl.points))
    for path in a.clouds:
        pc = o3d.io.read_point_cloud(path)
        p = np.asarray(pc.points)
        d = err(p)
        near = np.asarray(pc.compute_point_cloud_distance(xt)) <= 0.002
        c = categories(scene, mesh, n_bin, p)
        print("\n%s: %d points, median %.3f mm; %d within 2 mm of the xtion-alone cloud (median %.3f mm), %d others"
              % (path, len(p), 1e3 * np.median(d), int(near.sum()), 1e3 * np.median(d[near]), int((~near).sum())))
        print("| true surface | xtion's surface: points, median (mm) | others: points, median (mm), > 2 mm off |")
        print("|---|---|---|")
        for k in ("floor", "inner wall", "outer wall", "rim", "object"):
            m_in, m_out = (c == k) & near, (c == k) & ~near
            a_in = "%d, %.3f" % (m_in.sum(), 1e3 * np.median(d[m_in])) if m_in.any() else "0"
            a_out = ("%d, %.3f, %.0f %%" % (m_out.sum(), 1e3 * np.median(d[m_out]), 100 * np.mean(d[m_out] > 0.002))
                     if m_out.any() else "0")
            print("| %s | %s | %s |" % (k, a_in, a_out))
        near_xl = np.asarray(pc.compute_point_cloud_distance(xl)) <= 0.002
        extra = d[~near_xl]
        bounds = []
        for lim in (0.0005, 0.001, 0.002):
            e = extra[extra <= lim]
            bounds.append("<= %.1f mm: +%d points -> median %.4f mm" % (1e3 * lim, len(e), 1e3 * np.median(np.concatenate([d_xl, e]))))
        print("oracle (xtion+laser cloud, median %.4f mm, plus the points > 2 mm from it that lie within ... of the truth): %s"
              % (1e3 * np.median(d_xl), "; ".join(bounds)))


if __name__ == "__main__":
    main()
