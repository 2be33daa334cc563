#!/usr/bin/python3
"""edgefuse's TSDF space against Open3D 0.16's VoxelBlockGrid and UniformTSDFVolume, same run.

For each data set (same frames, poses, voxel, truncation) it runs
  * edgefuse: `edgefuse_tsdf_bench` (integration and raycast, thread CPU, one thread; raycast on
    2 threads, wall) and `edgefuse fuse --threads N` (integration wall per frame, the fused cloud);
  * Open3D's sparse `open3d.t.geometry.VoxelBlockGrid` on the CPU: `compute_unique_block_coordinates`
    + `integrate` timed per frame (a colour attribute where edgefuse integrates colour), then
    `ray_cast` of depth, vertex and normal from every pose on the final grid, at edgefuse's raycast
    resolution;
  * Open3D's legacy `UniformTSDFVolume` over edgefuse's cube (integration only: it has no raycast);
and prints ms per frame, the ratios (peer / edgefuse: above 1 = edgefuse faster), the distance
between edgefuse's and VoxelBlockGrid's clouds (median point-to-plane both ways, where both see), and the memory
each space holds, and how many voxels VoxelBlockGrid integrates per frame. Open3D runs in a child
process per thread count (OMP_NUM_THREADS must be set
before OpenMP starts).

  /usr/bin/python3 tools/bench/space_vs_open3d.py [--sets xtion,kitchen,tum] [--threads 1,2]
      [--build build/host] [--out /tmp/edgefuse_space_bench]

Targets: integration >= 2x and raycast >= 4x faster than VoxelBlockGrid with one thread, clouds
within half a voxel. The VM is shared and noisy: compare within one run; read the ratios.
"""

import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import tracking_vs_open3d as tv  # noqa: E402  (data set loading, beside this script)
from o3d_import import import_np_o3d  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
TARGET_INTEGRATE = 2.0
TARGET_RAYCAST = 4.0
NEAR_VOXELS = 3.0  # "where both see": a point counts when the other cloud is within 3 voxels

# key: (tracking_vs_open3d data set, frames, voxel m, trunc m, raycast pyramid level)
SETS = {
    "xtion": ("xtion", 20, 0.002, 0.008, 0),     # bin_rig_a xtion 320x240: the embedded default
    "kitchen": ("kitchen", 100, 0.01, 0.04, 1),  # 7-Scenes 640x480, raycast 320x240
    "tum": ("tum", 37, 0.01, 0.04, 1),           # TUM fr1/xyz 640x480, raycast 320x240
}


def die(msg, code=2):
    print(f"space_vs_open3d: error: {msg}", file=sys.stderr)
    sys.exit(code)


def run(cmd):
    p = subprocess.run([str(c) for c in cmd], capture_output=True, text=True)
    if p.returncode != 0:
        die(f"{' '.join(map(str, cmd))} failed (exit {p.returncode}):\n{(p.stdout + p.stderr)[-1500:]}", 1)
    return p.stdout


def grab(pattern, text, what):
    m = re.search(pattern, text, re.M)
    if not m:
        die(f"no '{what}' in the output:\n{text[-1500:]}", 1)
    return m


# ----------------------------------------------------------------------------------------------
# edgefuse


def edgefuse_runs(build, ds, frames, voxel, trunc, level, threads, out):
    """Integration and raycast figures of edgefuse, and its fused cloud (PLY)."""
    exe, bench = build / "tools/edgefuse", build / "tools/edgefuse_tsdf_bench"
    for x in (exe, bench):
        if not x.is_file():
            die(f"{x} not built (cmake --build --preset host --target edgefuse edgefuse_tsdf_bench)")
    sensor = ["--sensor", ds["sensor"]] if ds["sensor"] else []
    data = ds["path"]
    b = run([bench, data, *sensor, "--frames", frames, "--voxel", voxel, "--no-colour-map", "--reps", 3,
             "--cast-level", level, "--cast-threads", 2])
    res = {
        "integrate_cpu_ms": float(grab(r"integrate ([\d.]+) ms/frame thread CPU", b, "integrate").group(1)),
        "raycast_cpu_ms": float(grab(r"([\d.]+) ms on the final volume", b, "raycast").group(1)),
        "raycast_wall2_ms": float(grab(r"raycast on 2 threads: ([\d.]+) ms wall", b, "2-thread raycast").group(1)),
        "cast_size": (re.search(r"raycasts (\d+x\d+)", b) or grab(r"(\d+x\d+), \d+\^3", b, "size")).group(1),
    }
    for t in threads:
        f = run([exe, "fuse", data, *sensor, "--frames", frames, "--voxel", voxel, "--trunc", trunc,
                 "--threads", t, "--out", out / f"edgefuse_{ds['key']}_{t}.ply"])
        res[f"integrate_wall{t}_ms"] = float(grab(r"integrate_ms=([\d.]+)", f, "integrate_ms").group(1))
        res["header"] = f
    v = grab(r"^volume: (\d+)\^3 voxels .*origin ([-\d.]+),([-\d.]+),([-\d.]+)", res["header"], "volume")
    res["dim"] = int(v.group(1))
    res["origin"] = [float(v.group(i)) for i in (2, 3, 4)]
    res["colour"] = "registered colour" in res["header"]
    # The voxel pool's bricks in use (8^3 voxels of int16 distance + uint8 weight, + RGB8 + uint8
    # colour weight) and the brick index over the cube (slot, flags, work list, block mask: 17 bytes).
    res["bricks"] = int(grab(r"^space: (\d+) of \d+ bricks in use", res["header"], "space").group(1))
    voxel_bytes = 3 + (4 if ", colour," in res["header"] else 0)
    res["space_bytes"] = res["bricks"] * 512 * voxel_bytes + (res["dim"] // 8) ** 3 * 17
    res["cloud"] = str(out / f"edgefuse_{ds['key']}_{threads[0]}.ply")
    return res


# ----------------------------------------------------------------------------------------------
# Open3D (child process)


def intrinsic_matrix(np, cam, level):
    s = 0.5 ** level
    return np.array([[cam["fx"] * s, 0, (cam["cx"] + 0.5) * s - 0.5], [0, cam["fy"] * s, (cam["cy"] + 0.5) * s - 0.5],
                     [0, 0, 1]], dtype=np.float64)


def o3d_worker(args):
    np, o3d = import_np_o3d("space_vs_open3d")
    ds = tv.load_dataset(args.set_key, args.frames)
    cam = ds["cam"]
    lo, hi = cam["min_range"] * cam["depth_scale"], cam["max_range"] * cam["depth_scale"]
    depths, colours, extr = [], [], []
    for f in ds["frames"]:
        d = np.asarray(o3d.io.read_image(str(f["depth"]))).copy()
        d[(d == 65535) | (d < lo) | (d > hi)] = 0
        depths.append(o3d.t.geometry.Image(o3d.core.Tensor(np.ascontiguousarray(d))))
        if args.colour:
            c = np.asarray(o3d.io.read_image(str(f["colour"])))  # uint8, as Open3D takes it with uint16 depth
            colours.append(o3d.t.geometry.Image(o3d.core.Tensor(np.ascontiguousarray(c[:, :, :3]))))
        extr.append(o3d.core.Tensor(np.linalg.inv(f["gt"])))
    K = o3d.core.Tensor(intrinsic_matrix(np, cam, 0))
    Kc = o3d.core.Tensor(intrinsic_matrix(np, cam, args.level))
    w, h = cam["width"] >> args.level, cam["height"] >> args.level
    mult = args.trunc / args.voxel
    scale, dmax = float(cam["depth_scale"]), float(cam["max_range"])
    names = ("tsdf", "weight", "color") if args.colour else ("tsdf", "weight")
    dtypes = (o3d.core.float32,) * len(names)
    chans = ((1), (1), (3)) if args.colour else ((1), (1))
    vbg = o3d.t.geometry.VoxelBlockGrid(attr_names=names, attr_dtypes=dtypes, attr_channels=chans,
                                        voxel_size=args.voxel, block_resolution=args.block, block_count=args.blocks,
                                        device=o3d.core.Device("CPU:0"))
    integ_wall, integ_cpu, frame_blocks = [], [], []
    for i, (d, E) in enumerate(zip(depths, extr)):
        c0, t0 = time.process_time(), time.perf_counter()
        blocks = vbg.compute_unique_block_coordinates(d, K, E, scale, dmax, mult)
        frame_blocks.append(int(blocks.shape[0]))
        if args.colour:
            vbg.integrate(blocks, d, colours[i], K, K, E, scale, dmax, mult)
        else:
            vbg.integrate(blocks, d, K, E, scale, dmax, mult)
        integ_wall.append((time.perf_counter() - t0) * 1e3)
        integ_cpu.append((time.process_time() - c0) * 1e3)
    cast_wall, cast_cpu = [], []
    for d, E in zip(depths, extr):
        blocks = vbg.compute_unique_block_coordinates(d, K, E, scale, dmax, mult)
        c0, t0 = time.process_time(), time.perf_counter()
        r = vbg.ray_cast(blocks, Kc, E, w, h, ["depth", "vertex", "normal"], scale, 0.1, dmax, 1.0, mult)
        cast_wall.append((time.perf_counter() - t0) * 1e3)
        cast_cpu.append((time.process_time() - c0) * 1e3)
        del r
    pc = vbg.extract_point_cloud()
    o3d.t.io.write_point_cloud(args.cloud, pc)
    active = vbg.hashmap().size()
    vbytes = 4 * (5 if args.colour else 2)
    legacy = None
    if args.legacy_dim:
        vol = o3d.pipelines.integration.UniformTSDFVolume(
            length=args.legacy_dim * args.voxel, resolution=args.legacy_dim, sdf_trunc=args.trunc,
            color_type=(o3d.pipelines.integration.TSDFVolumeColorType.RGB8 if args.colour
                        else o3d.pipelines.integration.TSDFVolumeColorType.NoColor),
            origin=np.array(args.legacy_origin, dtype=np.float64))
        intr = o3d.camera.PinholeCameraIntrinsic(cam["width"], cam["height"], cam["fx"], cam["fy"], cam["cx"],
                                                 cam["cy"])
        legacy = {"wall": [], "cpu": []}
        for i, (d, E) in enumerate(zip(depths, extr)):
            col = colours[i].as_tensor().numpy() if args.colour else \
                np.zeros((cam["height"], cam["width"], 3), np.uint8)
            rgbd = o3d.geometry.RGBDImage.create_from_color_and_depth(
                o3d.geometry.Image(col), o3d.geometry.Image(d.as_tensor().numpy()), depth_scale=scale,
                depth_trunc=dmax, convert_rgb_to_intensity=False)
            c0, t0 = time.process_time(), time.perf_counter()
            vol.integrate(rgbd, intr, E.numpy())
            legacy["wall"].append((time.perf_counter() - t0) * 1e3)
            legacy["cpu"].append((time.process_time() - c0) * 1e3)
    with open(args.json, "w") as f:
        json.dump({"integ_wall": integ_wall, "integ_cpu": integ_cpu, "cast_wall": cast_wall, "cast_cpu": cast_cpu,
                   "active_blocks": active, "frame_blocks": frame_blocks, "space_bytes": active * args.block ** 3 * vbytes, "legacy": legacy,
                   "cast_size": f"{w}x{h}"}, f)
    return 0


def o3d_run(key, frames, voxel, trunc, level, colour, threads, out, legacy_dim, legacy_origin, block):
    js = out / f"o3d_{key}_{threads}.json"
    cloud = out / f"o3d_{key}_{threads}.ply"
    cmd = [sys.executable, __file__, "--o3d-worker", "--set-key", key, "--frames", str(frames), "--voxel", str(voxel),
           "--trunc", str(trunc), "--level", str(level), "--json", str(js), "--cloud", str(cloud),
           "--block", str(block)]
    if colour:
        cmd.append("--colour")
    if legacy_dim:
        cmd += ["--legacy-dim", str(legacy_dim), "--legacy-origin", *map(str, legacy_origin)]
    env = dict(os.environ, OMP_NUM_THREADS=str(threads))
    p = subprocess.run(cmd, env=env, capture_output=True, text=True)
    if p.returncode != 0:
        die(f"Open3D worker failed ({key}, {threads} threads):\n{(p.stdout + p.stderr)[-2000:]}", 1)
    with open(js) as f:
        r = json.load(f)
    r["cloud"] = str(cloud)
    return r


# ----------------------------------------------------------------------------------------------
# Clouds


def cloud_distance(a_path, b_path, voxel):
    """Median point-to-plane distance both ways, where both see. The two spaces sample the surface on
    grids half a voxel apart (Open3D's voxels sit at i * voxel, edgefuse's at (i + 0.5) * voxel), so
    point-to-point distances of two perfect clouds are already ~half a voxel: measure along the other
    cloud's normal at the nearest point instead."""
    np, o3d = import_np_o3d("space_vs_open3d")
    a, b = o3d.io.read_point_cloud(a_path), o3d.io.read_point_cloud(b_path)
    out = []
    for x, y in ((a, b), (b, a)):
        if not y.has_normals():
            y.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(20))
        P, Q, N = np.asarray(x.points), np.asarray(y.points), np.asarray(y.normals)
        if len(P) == 0 or len(Q) == 0:
            out.append(float("nan"))
            continue
        nns = o3d.core.nns.NearestNeighborSearch(o3d.core.Tensor(Q))
        nns.knn_index()
        idx = nns.knn_search(o3d.core.Tensor(P), 1)[0].numpy()[:, 0]
        d = P - Q[idx]
        near = np.linalg.norm(d, axis=1) <= NEAR_VOXELS * voxel
        plane = np.abs(np.sum(d * N[idx], axis=1))[near]
        out.append(float(np.median(plane)) if plane.size else float("nan"))
    return out


# ----------------------------------------------------------------------------------------------


def med(xs, skip_first=True):
    xs = xs[1:] if skip_first and len(xs) > 2 else xs
    return statistics.median(xs)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sets", default="xtion,kitchen,tum", help="comma list of " + ",".join(SETS))
    ap.add_argument("--threads", default="1,2")
    ap.add_argument("--build", default=str(REPO / "build/host"))
    ap.add_argument("--out", default="/tmp/edgefuse_space_bench")
    ap.add_argument("--block", type=int, default=8, help="VoxelBlockGrid block resolution (8: edgefuse's brick)")
    ap.add_argument("--o3d-worker", action="store_true", help=argparse.SUPPRESS)
    for a in ("--set-key", "--json", "--cloud"):
        ap.add_argument(a, help=argparse.SUPPRESS)
    ap.add_argument("--frames", type=int, help=argparse.SUPPRESS)
    ap.add_argument("--voxel", type=float, help=argparse.SUPPRESS)
    ap.add_argument("--trunc", type=float, help=argparse.SUPPRESS)
    ap.add_argument("--level", type=int, help=argparse.SUPPRESS)
    ap.add_argument("--colour", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--blocks", type=int, default=60000, help=argparse.SUPPRESS)
    ap.add_argument("--legacy-dim", type=int, default=0, help=argparse.SUPPRESS)
    ap.add_argument("--legacy-origin", type=float, nargs=3, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.o3d_worker:
        return o3d_worker(args)

    build, out = Path(args.build), Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    threads = [int(t) for t in args.threads.split(",")]
    keys = [k for k in args.sets.split(",") if k]
    for k in keys:
        if k not in SETS:
            die(f"--sets: no set '{k}' (choose from {', '.join(SETS)})")
    print(f"space_vs_open3d: {tv.git_state()}; build {build}; load {os.getloadavg()[0]:.1f}; "
          f"VoxelBlockGrid block resolution {args.block}")
    rows = []
    for k in keys:
        dkey, frames, voxel, trunc, level = SETS[k]
        ds = tv.load_dataset(dkey, frames)
        ef = edgefuse_runs(build, ds, len(ds["frames"]), voxel, trunc, level, threads, out)
        o3 = {t: o3d_run(dkey, len(ds["frames"]), voxel, trunc, level, ef["colour"], t, out,
                         ef["dim"] if t == threads[0] else 0, ef["origin"], args.block) for t in threads}
        first = o3[threads[0]]
        dist = cloud_distance(ef["cloud"], first["cloud"], voxel)
        row = {"set": ds["label"], "frames": len(ds["frames"]), "voxel": voxel, "trunc": trunc,
               "colour": ef["colour"], "cast": ef["cast_size"], "ef": ef, "o3": o3, "dist_mm": [d * 1e3 for d in dist]}
        rows.append(row)
        report(row, threads, args.block)
    with open(out / "results.json", "w") as f:
        json.dump(rows, f, indent=1, default=str)
    print(f"\nresults: {out / 'results.json'}")
    return 0


def report(r, threads, block):
    ef, o3 = r["ef"], r["o3"]
    t1 = threads[0]
    vbg_i = med(o3[t1]["integ_cpu"])
    vbg_c = med(o3[t1]["cast_cpu"])
    print(f"\n== {r['set']}: {r['frames']} frames, voxel {r['voxel'] * 1e3:g} mm, trunc {r['trunc'] * 1e3:g} mm, "
          f"{'with' if r['colour'] else 'no'} colour, raycast {ef['cast_size']} depth+vertex+normal")
    print(f"integrate, 1 thread CPU ms/frame: edgefuse {ef['integrate_cpu_ms']:.2f}  VoxelBlockGrid {vbg_i:.2f} "
          f"({vbg_i / ef['integrate_cpu_ms']:.2f}x, target {TARGET_INTEGRATE:g}x)", end="")
    leg = o3[t1].get("legacy")
    if leg:
        print(f"  UniformTSDFVolume {med(leg['cpu']):.2f} ({med(leg['cpu']) / ef['integrate_cpu_ms']:.2f}x)")
    else:
        print()
    for t in threads:
        vw = med(o3[t]["integ_wall"])
        print(f"integrate, {t} thread(s) wall ms/frame: edgefuse fuse {ef[f'integrate_wall{t}_ms']:.2f} (mean)  "
              f"VoxelBlockGrid {vw:.2f} ({vw / ef[f'integrate_wall{t}_ms']:.2f}x)")
    print(f"raycast, 1 thread CPU ms: edgefuse {ef['raycast_cpu_ms']:.2f}  VoxelBlockGrid {vbg_c:.2f} "
          f"({vbg_c / ef['raycast_cpu_ms']:.2f}x, target {TARGET_RAYCAST:g}x)")
    if 2 in o3:
        vw2 = med(o3[2]["cast_wall"])
        print(f"raycast, 2 threads wall ms: edgefuse {ef['raycast_wall2_ms']:.2f}  VoxelBlockGrid {vw2:.2f} "
              f"({vw2 / ef['raycast_wall2_ms']:.2f}x)")
    print(f"clouds edgefuse <-> VoxelBlockGrid (median point-to-plane where both see): {r['dist_mm'][0]:.2f} / "
          f"{r['dist_mm'][1]:.2f} mm (half a voxel: {r['voxel'] * 500:g} mm)")
    print(f"space memory: edgefuse {ef['space_bytes'] / 2**20:.1f} MiB ({ef['bricks']} bricks of 8^3 in use, "
          f"{ef['dim']}^3 index)  VoxelBlockGrid "
          f"{o3[t1]['space_bytes'] / 2**20:.1f} MiB in use ({o3[t1]['active_blocks']} blocks)")
    fb = statistics.median(o3[t1].get("frame_blocks") or [0])
    print(f"VoxelBlockGrid integrates {fb:.0f} blocks per frame (median): {fb * block ** 3 / 1e6:.2f} M voxels")


if __name__ == "__main__":
    sys.exit(main())
