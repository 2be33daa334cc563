#!/usr/bin/python3
"""edgefuse tracking vs Open3D 0.16 RGB-D odometry: ATE on four data sets in one run.

For each data set (TUM fr1/xyz 37 frames, 7-Scenes RedKitchen 300 frames, bin_rig_a xtion and tof):

  * edgefuse: `edgefuse track DATASET [--sensor S] --out traj.txt --threads N` for N in --threads
    (default 1,2), then `edgefuse eval ate traj.txt DATASET [--sensor S]`; its printed per-frame time
    split (the last `key=value` line of its output) is shown per thread count;
  * Open3D: o3d.pipelines.odometry.compute_rgbd_odometry chained frame to frame (source = frame k,
    target = frame k-1, init = identity, default OdometryOption with depth_min/depth_max = the
    sensor's range), starting from the first frame's ground-truth pose; on failure the frame keeps
    the previous pose (Open3D's own reconstruction system does the same). Every applicable
    intensity input is run, each with RGBDOdometryJacobianFromHybridTerm:
      - `colour`:     grey from the sensor's RGB (TUM, xtion: registered; 7-Scenes: NOT registered to
                      depth, run anyway because it is what the data set offers),
      - `amplitude`:  ToF amplitude as intensity (sqrt-compressed, one fixed scale per sequence: the
                      99th percentile of the first frame's non-zero amplitudes -> 255),
      - `depth-only`: a constant grey image: the photometric residual and its gradient vanish, so
                      the hybrid term reduces to Open3D's depth term (the only way to run Open3D's
                      RGB-D odometry on a depth-only sensor; RGBDOdometryJacobianFromColorTerm
                      cannot work without intensity);
    the trajectories are evaluated with the same `edgefuse eval ate` (and, as a cross-check, with
    this script's own numpy ATE);
  * prints ATE side by side (edgefuse vs every Open3D variant and the best of them) and checks the
    issue's targets (TUM <= 6 mm, 7-Scenes <= 3 cm, bin_rig_a xtion <= 2 mm, lower than Open3D on
    each, per-frame loop at 320x240 / 256^3 >= 30 fps on one core).

Run with Debian's interpreter (python3-open3d):

  /usr/bin/python3 tools/bench/tracking_vs_open3d.py [--datasets tum,kitchen,xtion,tof] [--threads 1,2]
      [--edgefuse build/bench/tools/edgefuse] [--out /tmp/edgefuse_tracking_bench] [--wait-track S]
      [--track-args "..."] [--dataset-args KEY="ARGS"] [--frames N] [--wait-quiet S] [--gt-as-estimate]
      [--no-open3d]
  /usr/bin/python3 tools/bench/tracking_vs_open3d.py --selfcheck    # edgefuse eval vs numpy

--gt-as-estimate feeds the ground truth (at the depth frames' stamps) through the edgefuse half
instead of `edgefuse track` (a pipeline check: ATE must be ~0), for when track does not exist yet.
--selfcheck compares `edgefuse eval ate/rpe` with an independent numpy implementation of TUM's
associate.py / evaluate_ate.py / evaluate_rpe.py on a perturbed copy of fr1/xyz's ground truth.
Open3D runs in a child process with OMP_NUM_THREADS=1; its time per frame is measured around
compute_rgbd_odometry only (images are loaded and converted before).
"""

import argparse
import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path
import o3d_import  # beside this script
from cpu_load import cpu_busy_s, child_cpu_s  # beside this script

REPO = Path(__file__).resolve().parents[2]
SHARED = Path(os.environ.get("EDGEFUSE_SHARED_DATA", "/work/shared/data"))

DATASETS = {
    # key: (folder under SHARED, rig sensor, label, ATE target in metres or None)
    "tum": ("tum_fr1_xyz_37", None, "TUM fr1/xyz (37 frames)", 0.006),
    "kitchen": ("7scenes_redkitchen_300", None, "7-Scenes RedKitchen (300 frames)", 0.03),
    "xtion": ("bin_rig_a", "xtion", "bin_rig_a xtion (20 frames)", 0.002),
    "tof": ("bin_rig_a", "tof", "bin_rig_a tof (20 frames)", None),
}
# Per-data-set `edgefuse track` arguments (replace with --dataset-args KEY="ARGS"): the board's
# default voxel (host-sim: 2 mm, a 0.512 m cube for the bin) is too small a volume for the room-sized
# TUM and 7-Scenes scenes; 1 cm x 256 = 2.56 m, as the TSDF benchmark and the guide's TUM example.
TRACK_ARGS = {"tum": ["--voxel", "0.01"], "kitchen": ["--voxel", "0.01"], "xtion": [], "tof": []}
TARGET_FPS = 30.0
MAX_DT = 0.02


def die(msg, code=2):
    print(f"tracking_vs_open3d: error: {msg}", file=sys.stderr)
    sys.exit(code)


def import_np_o3d():
    return o3d_import.import_np_o3d('tracking_vs_open3d')


# ----------------------------------------------------------------------------------------------
# Data sets (FORMATS.md): TUM folder, rig sensor folder, per-frame folder


def read_toml(path):
    import tomllib
    try:
        with open(path, "rb") as f:
            return tomllib.load(f)
    except (OSError, tomllib.TOMLDecodeError) as e:
        die(f"{path}: {e}")


def read_list(path):
    """TUM list 'timestamp path' -> [(stamp, abs path)]."""
    out = []
    with open(path) as f:
        for n, line in enumerate(f, 1):
            line = line.strip()
            if not line or line.startswith("#"):
                continue
            p = line.split()
            if len(p) != 2:
                die(f"{path}:{n}: expected 'timestamp path'")
            out.append((float(p[0]), Path(path).parent / p[1]))
    return sorted(out)


def read_tum_traj(path):
    """-> sorted [(stamp, 4x4 T_world_cam)]."""
    import numpy as np
    out = []
    with open(path) as f:
        for n, line in enumerate(f, 1):
            line = line.strip()
            if not line or line.startswith("#"):
                continue
            v = [float(x) for x in line.split()]
            if len(v) != 8:
                die(f"{path}:{n}: expected 8 values")
            out.append((v[0], tq_to_matrix(np.array(v[1:4]), np.array(v[4:8]))))
    out.sort(key=lambda p: p[0])
    return out


def tq_to_matrix(t, q):
    import numpy as np
    x, y, z, w = q / np.linalg.norm(q)
    R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                  [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                  [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, t
    return T


def matrix_to_tq(T):
    import numpy as np
    R = T[:3, :3]
    tr = np.trace(R)
    if tr > 0:
        s = 2 * np.sqrt(tr + 1)
        q = [(R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s, s / 4]
    else:
        i = int(np.argmax(np.diag(R)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2 * np.sqrt(1 + R[i, i] - R[j, j] - R[k, k])
        q = [0.0] * 4
        q[i] = s / 4
        q[j] = (R[j, i] + R[i, j]) / s
        q[k] = (R[k, i] + R[i, k]) / s
        q[3] = (R[k, j] - R[j, k]) / s
    q = np.array(q) / np.linalg.norm(q)
    if q[3] < 0:
        q = -q
    return T[:3, 3], q


def write_tum_traj(path, stamped, comment):
    with open(path, "w") as f:
        f.write(f"# {comment}\n# timestamp tx ty tz qx qy qz qw\n")
        for s, T in stamped:
            t, q = matrix_to_tq(T)
            f.write(f"{s:.6f} {t[0]:.9f} {t[1]:.9f} {t[2]:.9f} {q[0]:.9f} {q[1]:.9f} {q[2]:.9f} {q[3]:.9f}\n")


def nearest(stamped, t, max_dt=MAX_DT):
    """Nearest entry of a sorted [(stamp, x)] list within max_dt, else None."""
    import bisect
    i = bisect.bisect_left([s for s, _ in stamped], t)
    best = None
    for j in (i - 1, i):
        if 0 <= j < len(stamped) and abs(stamped[j][0] - t) < max_dt and (
                best is None or abs(stamped[j][0] - t) < abs(best[0] - t)):
            best = stamped[j]
    return best


def load_dataset(key, max_frames=0):
    """-> dict: cam (width, height, fx, fy, cx, cy, depth_scale, min_range, max_range), frames
    [{stamp, depth, colour, amplitude, gt}], colour_registered, path, sensor."""
    import numpy as np
    folder, sensor, label, target = DATASETS[key]
    root = SHARED / folder
    if not root.is_dir():
        die(f"{root} not found (set EDGEFUSE_SHARED_DATA)")
    ds = {"key": key, "path": root, "sensor": sensor, "label": label, "target": target}
    if sensor:  # rig set: rig.toml sensor + TUM folder
        rig = read_toml(root / "rig.toml")
        cam = next((s for s in rig.get("sensor", []) if s.get("name") == sensor), None)
        if cam is None:
            die(f"{root / 'rig.toml'}: no sensor '{sensor}'")
        seq = root / sensor
    else:
        seq = root
        cam = read_toml(root / "camera.toml")
    for k in ("width", "height", "fx", "fy", "cx", "cy", "depth_scale"):
        if k not in cam:
            die(f"{seq}: intrinsics lack '{k}'")
    cam = dict(cam)
    cam.setdefault("min_range", 0.0)
    cam.setdefault("max_range", 65.535 * 1000.0 / cam["depth_scale"])
    frames = []
    if (seq / "depth.txt").is_file():  # TUM layout
        depth = read_list(seq / "depth.txt")
        rgb = read_list(seq / "rgb.txt") if (seq / "rgb.txt").is_file() else []
        amp = read_list(seq / "amplitude.txt") if (seq / "amplitude.txt").is_file() else []
        gt = read_tum_traj(seq / "groundtruth.txt")
        for s, d in depth:
            c, a, g = nearest(rgb, s), nearest(amp, s), nearest(gt, s)
            frames.append({"stamp": s, "depth": d, "colour": c[1] if c else None, "amplitude": a[1] if a else None,
                           "gt": g[1] if g else None})
        ds["colour_registered"] = True
        ds["gt_all"] = gt
    else:  # per-frame layout: stamp = frame number
        for d in sorted(seq.glob("frame-*.depth.png")):
            n = int(d.name[6:12])
            p = seq / f"frame-{n:06d}.pose.txt"
            c = seq / f"frame-{n:06d}.color.jpg"
            frames.append({"stamp": float(n), "depth": d, "colour": c if c.is_file() else None, "amplitude": None,
                           "gt": np.loadtxt(p) if p.is_file() else None})
        ds["colour_registered"] = False
        ds["gt_all"] = [(f["stamp"], f["gt"]) for f in frames if f["gt"] is not None]
    if max_frames > 0:
        frames = frames[:max_frames]
    if not frames:
        die(f"{seq}: no frames")
    if frames[0]["gt"] is None:
        die(f"{seq}: the first frame has no ground-truth pose (needed as Open3D's start)")
    ds["cam"], ds["frames"] = cam, frames
    return ds


def variants_of(ds):
    v = []
    if any(f["colour"] is not None for f in ds["frames"]):
        v.append("colour")
    if any(f["amplitude"] is not None for f in ds["frames"]):
        v.append("amplitude")
    v.append("depth-only")
    return v


# ----------------------------------------------------------------------------------------------
# Open3D worker (child process, OMP_NUM_THREADS=1)


def o3d_worker(args):
    np, o3d = import_np_o3d()
    ds = load_dataset(args.dataset, args.frames)
    cam, frames, variant = ds["cam"], ds["frames"], args.variant
    intr = o3d.camera.PinholeCameraIntrinsic(cam["width"], cam["height"], cam["fx"], cam["fy"], cam["cx"], cam["cy"])
    option = o3d.pipelines.odometry.OdometryOption(depth_min=float(cam["min_range"]),
                                                    depth_max=float(cam["max_range"]))
    jac = o3d.pipelines.odometry.RGBDOdometryJacobianFromHybridTerm()
    shape = (cam["height"], cam["width"])
    grey = np.full(shape + (3,), 128, np.uint8)
    amp_scale = None
    rgbds = []
    for f in frames:
        depth = np.asarray(o3d.io.read_image(str(f["depth"])))
        if depth.dtype != np.uint16 or depth.shape != shape:
            die(f"{f['depth']}: expected a {shape[1]}x{shape[0]} 16-bit PNG, got {depth.dtype} {depth.shape}")
        if variant == "colour" and f["colour"] is not None:
            col = np.asarray(o3d.io.read_image(str(f["colour"])))
            if col.ndim == 2:
                col = np.repeat(col[:, :, None], 3, axis=2)
            col = np.ascontiguousarray(col[:, :, :3])
            if col.shape[:2] != shape:
                die(f"{f['colour']}: size {col.shape[1]}x{col.shape[0]}, depth is {shape[1]}x{shape[0]}")
        elif variant == "amplitude" and f["amplitude"] is not None:
            a = np.asarray(o3d.io.read_image(str(f["amplitude"]))).astype(np.float64)
            if amp_scale is None:
                nz = a[a > 0]
                amp_scale = float(np.percentile(nz, 99)) if nz.size else 1.0
            g = np.clip(255.0 * np.sqrt(a / amp_scale), 0, 255).astype(np.uint8)
            col = np.ascontiguousarray(np.repeat(g[:, :, None], 3, axis=2))
        else:
            col = grey
        rgbds.append(o3d.geometry.RGBDImage.create_from_color_and_depth(
            o3d.geometry.Image(col), o3d.geometry.Image(np.ascontiguousarray(depth)),
            depth_scale=float(cam["depth_scale"]), depth_trunc=float(cam["max_range"]),
            convert_rgb_to_intensity=True))
    T = np.array(frames[0]["gt"], dtype=np.float64)
    traj = [(frames[0]["stamp"], T.copy())]
    ms, cpu_ms, fails = [], [], 0
    for k in range(1, len(frames)):
        c0, t0 = time.process_time(), time.perf_counter()
        ok, T_prev_cur, _ = o3d.pipelines.odometry.compute_rgbd_odometry(
            rgbds[k], rgbds[k - 1], intr, np.eye(4), jac, option)
        t1, c1 = time.perf_counter(), time.process_time()
        ms.append((t1 - t0) * 1e3)
        cpu_ms.append((c1 - c0) * 1e3)
        if ok:
            T = T @ T_prev_cur  # T_world_k = T_world_{k-1} T_{k-1}_k (source k mapped into target k-1)
        else:
            fails += 1
        traj.append((frames[k]["stamp"], T.copy()))
    write_tum_traj(args.o3d_out, traj, f"Open3D {o3d.__version__} RGB-D odometry ({variant}, hybrid term), "
                                       f"{ds['label']}, chained from the first ground-truth pose")
    with open(args.o3d_json, "w") as f:
        json.dump({"ms": ms, "cpu_ms": cpu_ms, "fails": fails, "frames": len(frames), "open3d": o3d.__version__,
                   "omp_num_threads": os.environ.get("OMP_NUM_THREADS"), "amp_scale": amp_scale}, f)
    return 0


# ----------------------------------------------------------------------------------------------
# Independent numpy ATE / RPE (TUM associate.py, evaluate_ate.py, evaluate_rpe.py --fixed_delta
# --delta_unit f), for the cross-checks


def np_associate(est_stamps, gt_stamps, max_dt=MAX_DT):
    """associate.py(first=gt, second=est): greedy by difference, one-to-one. -> [(i_est, i_gt)]."""
    import numpy as np
    gs = np.asarray(gt_stamps)
    cand = []
    for j, t in enumerate(est_stamps):
        lo, hi = np.searchsorted(gs, t - max_dt), np.searchsorted(gs, t + max_dt, side="right")
        for i in range(lo, hi):
            d = abs(gs[i] - t)
            if d < max_dt:
                cand.append((d, i, j))
    cand.sort()
    used_g, used_e, out = set(), set(), []
    for d, i, j in cand:
        if i in used_g or j in used_e:
            continue
        used_g.add(i)
        used_e.add(j)
        out.append((j, i))
    out.sort()
    return out


def np_ate(est, gt, max_dt=MAX_DT):
    """est, gt: sorted [(stamp, 4x4)]. -> (rmse, count, errors)."""
    import numpy as np
    pairs = np_associate([s for s, _ in est], [s for s, _ in gt], max_dt)
    if len(pairs) < 3:
        return float("nan"), len(pairs), []
    model = np.array([est[j][1][:3, 3] for j, _ in pairs]).T  # 3 x n
    data = np.array([gt[i][1][:3, 3] for _, i in pairs]).T
    mz = model - model.mean(1, keepdims=True)
    dz = data - data.mean(1, keepdims=True)
    W = dz @ mz.T
    U, _, Vh = np.linalg.svd(W)
    S = np.eye(3)
    if np.linalg.det(U) * np.linalg.det(Vh) < 0:
        S[2, 2] = -1
    R = U @ S @ Vh
    t = data.mean(1) - R @ model.mean(1)
    err = np.sqrt(((R @ model + t[:, None] - data) ** 2).sum(0))
    return float(np.sqrt((err ** 2).mean())), len(pairs), err


def np_ate_unaligned(est, gt, max_dt=MAX_DT):
    """Position RMSE without any alignment (meaningful here: every run starts at the GT pose)."""
    import numpy as np
    pairs = np_associate([s for s, _ in est], [s for s, _ in gt], max_dt)
    if not pairs:
        return float("nan")
    d = np.array([est[j][1][:3, 3] - gt[i][1][:3, 3] for j, i in pairs])
    return float(np.sqrt((d ** 2).sum(1).mean()))


def np_rpe(est, gt, delta=1):
    import numpy as np
    gs = np.array([s for s, _ in gt])
    max_dt = 2 * np.median(np.diff(gs))
    n = len(est)
    tr, rot = [], []

    def closest(t):
        i = int(np.searchsorted(gs, t))
        c = [k for k in (i - 1, i) if 0 <= k < len(gs)]
        return min(c, key=lambda k: abs(gs[k] - t))

    for i in range(n):
        j = min(i + delta, n - 1)
        if j == n - 1:
            continue
        g0, g1 = closest(est[i][0]), closest(est[j][0])
        if abs(gs[g0] - est[i][0]) > max_dt or abs(gs[g1] - est[j][0]) > max_dt:
            continue
        inv = np.linalg.inv
        e = inv(inv(est[j][1]) @ est[i][1]) @ (inv(gt[g1][1]) @ gt[g0][1])
        tr.append(np.linalg.norm(e[:3, 3]))
        rot.append(np.arccos(min(1.0, max(-1.0, (np.trace(e[:3, :3]) - 1) / 2))))
    tr, rot = np.array(tr), np.array(rot)
    return float(np.sqrt((tr ** 2).mean())), float(np.degrees(np.sqrt((rot ** 2).mean()))), len(tr)


# ----------------------------------------------------------------------------------------------
# edgefuse runs

ATE_RE = re.compile(r"^ate_rmse_m=([-\d.eE+naNinf]+) count=(\d+)\s*$", re.M)
RPE_RE = re.compile(r"^rpe_trans_rmse_m=(\S+) rpe_rot_rmse_deg=(\S+) count=(\d+)\s*$", re.M)
KV_LINE_RE = re.compile(r"^(?:[A-Za-z_][\w.]*=\S+)(?:\s+[A-Za-z_][\w.]*=\S+)*\s*$", re.M)


def find_edgefuse(given):
    if given:
        p = Path(given)
        if not (p.is_file() and os.access(p, os.X_OK)):
            die(f"--edgefuse {given}: not an executable file")
        return p
    for c in ("build/bench", "build/host", "build/eval", "build/track", "build/dev"):
        p = REPO / c / "tools/edgefuse"
        if p.is_file() and os.access(p, os.X_OK):
            try:
                r = subprocess.run([str(p), "help"], capture_output=True, text=True, timeout=10)
            except OSError:
                continue  # cross-compiled
            if " eval " in r.stdout:
                return p
    die("no host edgefuse binary with the eval command found; build one (cmake -S . -B build/bench -G Ninja && "
        "cmake --build build/bench --target edgefuse) or pass --edgefuse PATH")


def has_track(exe):
    r = subprocess.run([str(exe), "help"], capture_output=True, text=True)
    return re.search(r"^\s+track\s", r.stdout, re.M) is not None


def run(cmd, log=None):
    r = subprocess.run([str(c) for c in cmd], capture_output=True, text=True)
    if log:
        Path(log).write_text("$ " + " ".join(str(c) for c in cmd) + "\n" + r.stdout + r.stderr)
    return r


def cmd_str(cmd):
    return " ".join(str(c) for c in cmd)


def eval_ate(exe, traj, ds, log):
    cmd = [exe, "eval", "ate", traj, ds["path"]] + (["--sensor", ds["sensor"]] if ds["sensor"] else [])
    r = run(cmd, log)
    m = ATE_RE.search(r.stdout)
    if r.returncode != 0 or not m:
        return {"error": (r.stderr.strip() or r.stdout.strip())[-400:], "cmd": cmd_str(cmd)}
    return {"rmse": float(m.group(1)), "count": int(m.group(2)), "cmd": cmd_str(cmd)}


def eval_rpe(exe, traj, ds, log):
    cmd = [exe, "eval", "rpe", traj, ds["path"]] + (["--sensor", ds["sensor"]] if ds["sensor"] else [])
    r = run(cmd, log)
    m = RPE_RE.search(r.stdout)
    if r.returncode != 0 or not m:
        return {"error": (r.stderr.strip() or r.stdout.strip())[-400:]}
    return {"trans": float(m.group(1)), "rot_deg": float(m.group(2)), "count": int(m.group(3))}


def parse_kv(line):
    out = {}
    for tok in line.split():
        k, v = tok.split("=", 1)
        try:
            out[k] = float(v)
        except ValueError:
            out[k] = v
    return out


def wait_quiet(max_wait_s, busy_cores=0.3):
    """Wait (up to max_wait_s) until the other processes use less than busy_cores cores."""
    if max_wait_s <= 0:
        return
    t_end = time.time() + max_wait_s
    while True:
        b0 = cpu_busy_s()
        time.sleep(2.0)
        if (cpu_busy_s() - b0) / 2.0 < busy_cores or time.time() >= t_end:
            return
        time.sleep(3.0)


def run_track(exe, ds, threads, out, extra, quiet_s=0, timeout_s=None):
    traj = out / f"edgefuse_{ds['key']}_t{threads}.txt"
    cmd = [exe, "track", ds["path"]] + (["--sensor", ds["sensor"]] if ds["sensor"] else []) + \
          ["--out", traj, "--threads", threads] + extra
    wait_quiet(quiet_s)
    t0, b0, c0 = time.perf_counter(), cpu_busy_s(), child_cpu_s()
    log = out / f"edgefuse_{ds['key']}_t{threads}.log"
    with open(log, "w") as f:  # streamed, so that a long run's progress can be followed
        f.write("$ " + cmd_str(cmd) + "\n")
        f.flush()
        try:
            r = subprocess.run([str(c) for c in cmd], stdout=f, stderr=subprocess.PIPE, text=True, timeout=timeout_s)
        except subprocess.TimeoutExpired:
            r = None
    wall = time.perf_counter() - t0
    if r is None:
        lines = [l for l in log.read_text().splitlines() if l.startswith("frame ")]
        return {"cmd": cmd_str(cmd), "wall_s": wall, "traj": traj,
                "error": f"TIMEOUT: killed after {timeout_s:.0f} s; last frame line: "
                         f"{lines[-1][:120] if lines else '(none)'}"}
    r.stdout = log.read_text()
    own = child_cpu_s() - c0
    other = max(0.0, (cpu_busy_s() - b0 - own) / max(wall, 1e-9))
    res = {"cmd": cmd_str(cmd), "wall_s": wall, "cpu_s": own, "other_cores": other, "traj": traj}
    if r.returncode != 0:
        res["error"] = f"exit {r.returncode}: " + (r.stderr.strip() or r.stdout.strip())[-600:]
        return res
    kv = KV_LINE_RE.findall(r.stdout)
    res["summary"] = parse_kv(kv[-1]) if kv else {}
    res["summary_line"] = kv[-1].strip() if kv else ""
    return res


def loop_ms(summary):
    """Per-frame loop time from track's summary: its total if it prints one, else the sum of *_ms."""
    for k in ("total_ms", "frame_ms", "loop_ms"):
        if isinstance(summary.get(k), float):
            return summary[k], k
    parts = [v for k, v in summary.items() if k.endswith("_ms") and isinstance(v, float)]
    return (sum(parts), "sum of *_ms") if parts else (None, None)


def gt_estimate(ds, path):
    """The ground truth at the depth frames' stamps as a TUM file (pipeline check)."""
    stamped = [(f["stamp"], f["gt"]) for f in ds["frames"] if f["gt"] is not None]
    write_tum_traj(path, stamped, f"ground truth of {ds['label']} at the depth stamps (--gt-as-estimate)")


def git_state():
    try:
        head = subprocess.run(["git", "-C", str(REPO), "rev-parse", "--short", "HEAD"], capture_output=True,
                              text=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(REPO), "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True).stdout.splitlines()
        return f"repo HEAD {head or '?'}, {len(dirty)} tracked files modified"
    except OSError:
        return "git not available"


def cpu_model():
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return "?"


def fmt_m(x):
    return "-" if x is None else f"{x * 1000:.2f} mm"


# ----------------------------------------------------------------------------------------------


def selfcheck(exe, out):
    """edgefuse eval vs numpy on fr1/xyz ground truth, perturbed."""
    np, _ = import_np_o3d()
    gt_path = SHARED / "tum_fr1_xyz_37/groundtruth.txt"
    gt = read_tum_traj(gt_path)
    rng = np.random.default_rng(1)
    ax = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    ang = 1.1
    K = np.array([[0, -ax[2], ax[1]], [ax[2], 0, -ax[0]], [-ax[1], ax[0], 0]])
    M = np.eye(4)
    M[:3, :3] = np.eye(3) + np.sin(ang) * K + (1 - np.cos(ang)) * K @ K
    M[:3, 3] = [0.7, -1.2, 0.4]
    est = []
    for k, (s, T) in enumerate(gt):
        if k % 7 == 3:
            continue  # drop some poses
        E = M @ T
        E[:3, 3] += rng.normal(0, 0.01, 3)  # 1 cm per axis
        d = rng.normal(0, 0.01, 3)  # small rotation noise (rad)
        Kd = np.array([[0, -d[2], d[1]], [d[2], 0, -d[0]], [-d[1], d[0], 0]])
        E[:3, :3] = E[:3, :3] @ (np.eye(3) + Kd + Kd @ Kd / 2)
        u, _, vt = np.linalg.svd(E[:3, :3])
        E[:3, :3] = u @ vt
        est.append((s + rng.uniform(-0.004, 0.004), E))  # stamp jitter: association matters
    # Write with the stamps rounded as in the file, and re-read for numpy, so both see the same input.
    est_path = out / "selfcheck_est.txt"
    write_tum_traj(est_path, est, "selfcheck: fr1/xyz ground truth moved rigidly, 1 cm / 0.01 rad noise, jitter")
    est_r = read_tum_traj(est_path)
    ok = True
    print(f"== selfcheck: {est_path} ({len(est_r)} poses) vs {gt_path} ({len(gt)} poses)")
    for max_dt in (0.02, 0.003):
        r = run([exe, "eval", "ate", est_path, gt_path, "--max-dt", max_dt])
        m = ATE_RE.search(r.stdout)
        rm, n, _ = np_ate(est_r, gt, max_dt)
        good = m is not None and abs(float(m.group(1)) - rm) < 2e-6 and int(m.group(2)) == n
        ok &= good
        print(f"ATE max-dt {max_dt}: edgefuse {m.group(1) if m else r.stderr.strip()} m over "
              f"{m.group(2) if m else '?'} pairs; numpy {rm:.6f} m over {n} pairs -> {'OK' if good else 'MISMATCH'}")
    for delta in (1, 5):
        r = run([exe, "eval", "rpe", est_path, gt_path, "--delta", delta])
        m = RPE_RE.search(r.stdout)
        t, rot, n = np_rpe(est_r, gt, delta)
        good = (m is not None and abs(float(m.group(1)) - t) < 2e-6 and abs(float(m.group(2)) - rot) < 2e-4
                and int(m.group(3)) == n)
        ok &= good
        print(f"RPE delta {delta}: edgefuse {m.group(1) if m else r.stderr.strip()} m / "
              f"{m.group(2) if m else '?'} deg over {m.group(3) if m else '?'} pairs; numpy {t:.6f} m / {rot:.6f} deg "
              f"over {n} pairs -> {'OK' if good else 'MISMATCH'}")
    # Mirror image: a library without the det sign check reports ~noise only.
    mir = [(s, np.diag([-1.0, 1, 1, 1]) @ T) for s, T in gt[::10]]
    mpath = out / "selfcheck_mirror.txt"
    with open(mpath, "w") as f:  # positions only matter for ATE; keep the GT rotations
        for (s, T), (_, G) in zip(mir, gt[::10]):
            _, q = matrix_to_tq(G)
            f.write(f"{s:.6f} {T[0, 3]:.9f} {T[1, 3]:.9f} {T[2, 3]:.9f} {q[0]:.9f} {q[1]:.9f} {q[2]:.9f} {q[3]:.9f}\n")
    r = run([exe, "eval", "ate", mpath, gt_path])
    m = ATE_RE.search(r.stdout)
    rm, n, _ = np_ate(read_tum_traj(mpath), gt)
    good = m is not None and abs(float(m.group(1)) - rm) < 2e-6 and rm > 1e-3
    ok &= good
    print(f"ATE of the mirrored ground truth: edgefuse {m.group(1) if m else '?'} m, numpy (with sign check) {rm:.6f} m "
          f"-> {'OK' if good else 'MISMATCH'} (without the check it would be 0)")
    print("selfcheck:", "PASS" if ok else "FAIL")
    return 0 if ok else 1


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--datasets", default="tum,kitchen,xtion,tof", help="comma-separated subset of "
                    + ",".join(DATASETS))
    ap.add_argument("--frames", type=int, default=0, metavar="N",
                    help="only the first N frames of each data set (track --frames N; default: all)")
    ap.add_argument("--threads", default="1,2", help="edgefuse track thread counts (default 1,2; ATE from the first)")
    ap.add_argument("--edgefuse", help="edgefuse binary (default: build/bench, build/host, build/eval, ...)")
    ap.add_argument("--out", default="/tmp/edgefuse_tracking_bench", help="trajectories and logs (not the repo)")
    ap.add_argument("--wait-track", type=float, default=0, metavar="S",
                    help="poll `edgefuse help` up to S seconds for the track command (default 0)")
    ap.add_argument("--track-timeout-per-frame", type=float, default=10.0, metavar="S",
                    help="kill an `edgefuse track` run after S seconds per frame + 60 s (default 10)")
    ap.add_argument("--track-args", default="", help="extra arguments for every `edgefuse track` run")
    ap.add_argument("--dataset-args", action="append", default=[], metavar='KEY="ARGS"',
                    help="replace one data set's default track arguments (defaults: "
                         + "; ".join(f"{k}: {' '.join(v) or 'none'}" for k, v in TRACK_ARGS.items()) + ")")
    ap.add_argument("--gt-as-estimate", action="store_true",
                    help="evaluate the ground truth as edgefuse's estimate (pipeline check) instead of running track")
    ap.add_argument("--no-open3d", action="store_true", help="skip the Open3D half")
    ap.add_argument("--wait-quiet", type=float, default=0, metavar="S",
                    help="before each edgefuse track run wait up to S seconds for other processes to use < 0.3 "
                         "cores (default 0: don't wait); the load seen during each run is printed either way")
    ap.add_argument("--selfcheck", action="store_true", help="compare edgefuse eval with numpy and exit")
    # internal: Open3D child process
    ap.add_argument("--o3d-worker", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--dataset", help=argparse.SUPPRESS)
    ap.add_argument("--variant", help=argparse.SUPPRESS)
    ap.add_argument("--o3d-out", help=argparse.SUPPRESS)
    ap.add_argument("--o3d-json", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.o3d_worker:
        return o3d_worker(args)

    keys = [k for k in args.datasets.split(",") if k]
    for k in keys:
        if k not in DATASETS:
            die(f"--datasets: unknown '{k}' (known: {', '.join(DATASETS)})")
    try:
        threads = [int(t) for t in args.threads.split(",")]
        assert threads and all(t >= 1 for t in threads)
    except (ValueError, AssertionError):
        die(f"--threads: expected positive integers separated by commas, got '{args.threads}'")
    np, o3d = import_np_o3d()
    exe = find_edgefuse(args.edgefuse)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.selfcheck:
        return selfcheck(exe, out)

    print(f"== host: {os.cpu_count()} CPUs ({cpu_model()}), load average "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    print(f"edgefuse: {exe} (built {time.strftime('%Y-%m-%d %H:%M', time.localtime(exe.stat().st_mtime))}; "
          f"{git_state()}); Open3D {o3d.__version__}; data {SHARED}")
    track = False
    if not args.gt_as_estimate:
        t_end = time.time() + args.wait_track
        while not (track := has_track(exe)) and time.time() < t_end:
            time.sleep(min(30.0, max(0.0, t_end - time.time())))
        if not track:
            print(f"NOTE: `{exe} help` lists no track command: the edgefuse half is skipped "
                  f"(--gt-as-estimate runs the pipeline on the ground truth instead)")
    extra = args.track_args.split()
    per_ds = {k: list(v) for k, v in TRACK_ARGS.items()}
    for item in args.dataset_args:
        k, sep, v = item.partition("=")
        if not sep or k not in DATASETS:
            die(f"--dataset-args: expected KEY=ARGS with KEY one of {', '.join(DATASETS)}, got '{item}'")
        per_ds[k] = v.split()
    results = {}
    for key in keys:
        ds = load_dataset(key, args.frames)
        cam = ds["cam"]
        print(f"\n== {ds['label']}: {ds['path']}{' --sensor ' + ds['sensor'] if ds['sensor'] else ''}, "
              f"{len(ds['frames'])} frames, {cam['width']}x{cam['height']}")
        res = {"label": ds["label"], "res": f"{cam['width']}x{cam['height']}", "frames": len(ds["frames"]),
               "target": ds["target"], "edgefuse": {}, "open3d": {}}
        # --- edgefuse
        if args.gt_as_estimate:
            traj = out / f"gt_as_estimate_{key}.txt"
            gt_estimate(ds, traj)
            a = eval_ate(exe, traj, ds, out / f"gt_as_estimate_{key}_ate.log")
            rp = eval_rpe(exe, traj, ds, out / f"gt_as_estimate_{key}_rpe.log")
            res["edgefuse"]["gt"] = {"ate": a, "rpe": rp}
            print(f"edgefuse (GT as estimate, pipeline check): ATE {fmt_m(a.get('rmse'))} over {a.get('count')} poses "
                  f"{a.get('error', '')}; RPE {fmt_m(rp.get('trans'))}, {rp.get('rot_deg', float('nan')):.4f} deg")
        elif track:
            for t in threads:
                fr = ["--frames", args.frames] if args.frames > 0 else []
                tr = run_track(exe, ds, t, out, per_ds[key] + fr + extra, args.wait_quiet,
                               args.track_timeout_per_frame * len(ds["frames"]) + 60)
                if "error" in tr:
                    print(f"edgefuse track t{t}: FAILED {tr['error']}\n    [{tr['cmd']}]")
                    res["edgefuse"][t] = tr
                    continue
                tr["ate"] = eval_ate(exe, tr["traj"], ds, out / f"edgefuse_{key}_t{t}_ate.log")
                tr["ate_unaligned"] = np_ate_unaligned(read_tum_traj(tr["traj"]), ds["gt_all"])
                tr["rpe"] = eval_rpe(exe, tr["traj"], ds, out / f"edgefuse_{key}_t{t}_rpe.log")
                lm, how = loop_ms(tr["summary"])
                tr["loop_ms"], tr["loop_how"] = lm, how
                tr["traj"] = str(tr["traj"])
                res["edgefuse"][t] = tr
                a, rp = tr["ate"], tr["rpe"]
                print(f"edgefuse track t{t}: ATE {fmt_m(a.get('rmse'))} over {a.get('count')} poses {a.get('error', '')}"
                      f"(unaligned {fmt_m(tr['ate_unaligned'])})"
                      f"; RPE {fmt_m(rp.get('trans'))}/frame, {rp.get('rot_deg', float('nan')):.3f} deg/frame; "
                      f"per frame: {tr['summary_line'] or '(no key=value summary line)'}"
                      + (f" -> loop {lm:.2f} ms ({how}) = {1000 / lm:.1f} fps" if lm else "")
                      + f"; run: {tr['wall_s']:.1f} s wall, {tr['cpu_s']:.1f} s CPU, other processes "
                        f"{tr['other_cores']:.2f} cores"
                      + f"\n    [{tr['cmd']}]\n    [{a.get('cmd')}]")
        # --- Open3D
        if not args.no_open3d:
            for v in variants_of(ds):
                traj = out / f"open3d_{key}_{v}.txt"
                js = out / f"open3d_{key}_{v}.json"
                env = dict(os.environ, OMP_NUM_THREADS="1")
                r = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--o3d-worker", "--dataset", key,
                                    "--frames", str(args.frames), "--variant", v, "--o3d-out", str(traj), "--o3d-json", str(js)], env=env)
                if r.returncode != 0:
                    print(f"Open3D {v}: worker FAILED (exit {r.returncode})")
                    continue
                w = json.loads(js.read_text())
                a = eval_ate(exe, traj, ds, out / f"open3d_{key}_{v}_ate.log")
                rp = eval_rpe(exe, traj, ds, out / f"open3d_{key}_{v}_rpe.log")
                np_rm, np_n, _ = np_ate(read_tum_traj(traj), ds["gt_all"])
                res["open3d"][v] = {"ate": a, "rpe": rp, "numpy_ate": np_rm, "numpy_count": np_n,
                                    "ate_unaligned": np_ate_unaligned(read_tum_traj(traj), ds["gt_all"]),
                                    "ms_median": float(np.median(w["ms"])) if w["ms"] else None,
                                    "cpu_ms_median": float(np.median(w["cpu_ms"])) if w["cpu_ms"] else None,
                                    "fails": w["fails"], "amp_scale": w["amp_scale"]}
                agree = "agrees" if abs(a.get("rmse", 1e9) - np_rm) < 2e-6 else "DIFFERS"
                print(f"Open3D {v:10s}: ATE {fmt_m(a.get('rmse'))} over {a.get('count')} poses {a.get('error', '')}"
                      f"(numpy {np_rm * 1000:.2f} mm, {agree}; unaligned {fmt_m(res['open3d'][v]['ate_unaligned'])})"
                      f"; RPE {fmt_m(rp.get('trans'))}/frame, "
                      f"{rp.get('rot_deg', float('nan')):.3f} deg/frame; {w['fails']} failed frames; "
                      f"{res['open3d'][v]['ms_median']:.1f} ms/frame wall, {res['open3d'][v]['cpu_ms_median']:.1f} ms "
                      f"CPU (medians, OMP_NUM_THREADS=1)")
        results[key] = res

    # --- summary
    print("\n== ATE summary (RMSE after rigid alignment, `edgefuse eval ate`)")
    hdr = f"{'data set':34s} {'res':>8s} {'edgefuse':>10s} " + " ".join(
        f"{'o3d ' + v:>15s}" for v in ("colour", "amplitude", "depth-only")) + f" {'target':>8s}  verdict"
    print(hdr)
    md = ["| data set | resolution | edgefuse ATE | Open3D colour | Open3D amplitude | Open3D depth-only | target | "
          "met? |", "|---|---|---|---|---|---|---|---|"]
    md_un = ["| data set | edgefuse | Open3D colour | Open3D amplitude | Open3D depth-only |", "|---|---|---|---|---|"]
    t0 = threads[0]
    for key, res in results.items():
        ef = res["edgefuse"].get("gt") or res["edgefuse"].get(t0) or {}
        ef_ate = ef.get("ate", {}).get("rmse")
        o3 = {v: r["ate"].get("rmse") for v, r in res["open3d"].items()}
        o3_best = min([x for x in o3.values() if x is not None], default=None)
        verdict = []
        if ef_ate is None:
            verdict.append("edgefuse not run")
        else:
            if res["target"] is not None:
                verdict.append(f"target {'MET' if ef_ate <= res['target'] else 'NOT met'}")
            if o3_best is not None:
                verdict.append(f"{'better' if ef_ate < o3_best else 'NOT better'} than best Open3D")
        cells = [fmt_m(o3.get(v)) for v in ("colour", "amplitude", "depth-only")]
        tgt = fmt_m(res["target"]) if res["target"] else "-"
        print(f"{res['label']:34s} {res['res']:>8s} {fmt_m(ef_ate):>10s} " + " ".join(f"{c:>15s}" for c in cells)
              + f" {tgt:>8s}  {'; '.join(verdict)}")
        md.append(f"| {res['label']} | {res['res']} | {fmt_m(ef_ate)} | " + " | ".join(cells) + f" | {tgt} | "
                  f"{'; '.join(verdict)} |")
        un = [fmt_m(res["open3d"][v].get("ate_unaligned")) if v in res["open3d"] else "-"
              for v in ("colour", "amplitude", "depth-only")]
        md_un.append(f"| {res['label']} | {fmt_m(ef.get('ate_unaligned'))} | " + " | ".join(un) + " |")
    if track and not args.gt_as_estimate:
        print("\n== edgefuse per-frame time split (track's own figures)")
        for key, res in results.items():
            for t, tr in res["edgefuse"].items():
                if "summary_line" in tr:
                    lm = tr.get("loop_ms")
                    fps = f", {1000 / lm:.1f} fps" if lm and "fps" not in tr["summary"] else ""
                    print(f"{res['label']:34s} {res['res']:>8s} t{t}: {tr['summary_line']}{fps} "
                          f"(whole run {1000 * tr['cpu_s'] / res['frames']:.1f} ms CPU/frame incl. start-up and "
                          f"file loading; other processes {tr['other_cores']:.2f} cores)")
        x = results.get("xtion", {}).get("edgefuse", {}).get(1)
        if x and x.get("loop_ms"):
            print(f"target: per-frame loop at 320x240 / 256^3 on one core >= {TARGET_FPS:.0f} fps: "
                  f"{1000 / x['loop_ms']:.1f} fps -> {'MET' if 1000 / x['loop_ms'] >= TARGET_FPS else 'NOT met'} "
                  f"(bin_rig_a xtion, --threads 1; volume as track's defaults/--track-args)")
    print("\n" + "\n".join(md))
    print("\nPosition RMSE without alignment (every trajectory starts at the first ground-truth pose):\n")
    print("\n".join(md_un))
    (out / "summary.json").write_text(json.dumps(results, indent=1, default=str))
    print(f"\n(trajectories, logs and summary.json in {out})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
