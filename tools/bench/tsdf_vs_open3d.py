#!/usr/bin/python3
"""edgefuse TSDF integration vs Open3D 0.16's UniformTSDFVolume, in one run on one machine.

Fuses the same 7-Scenes frames with `edgefuse fuse` and with
o3d.pipelines.integration.UniformTSDFVolume at the same voxel size (1 cm), truncation (4 cm),
volume (256^3 voxels, same origin), frames and thread count, then prints

  * integration time per frame of both and their ratio (Open3D / edgefuse),
  * the distance between the two extracted clouds (edgefuse's PLY vs Open3D's
    extract_point_cloud()), both ways, restricted to "where both see",
  * a per-grid-edge comparison of the zero crossings (both clouds sit on the same grid edges,
    so the shift along a shared edge is the difference of the two TSDFs' zero crossings),
  * a second block: edgefuse raycast times (320x240 on one core from bin_rig_a/xtion, and
    640x480 from tum_fr1_xyz_37 on 1 and 2 threads),
  * whether edgefuse's PLY opens in Open3D (and in PCL's pcl_ply2pcd if installed),

and checks the issue's targets. Run it with Debian's interpreter, which has python3-open3d:

  /usr/bin/python3 tools/bench/tsdf_vs_open3d.py [--frames 300] [--threads 2[,1]] \
      [--edgefuse build/bench/tools/edgefuse] [--out /tmp/edgefuse_bench]

Open3D runs in a child process per thread count so that OMP_NUM_THREADS takes effect before
OpenMP starts. Open3D's time is measured around `integrate` only: every frame is read, masked
and turned into an RGBDImage before the timed loop. edgefuse's figure is its own integrate_ms
(excludes file loading). Figures on a shared VM are noisy: compare within one run.
"""

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path
import o3d_import  # beside this script
from cpu_load import cpu_busy_s  # beside this script

VOXEL_M = 0.01
TRUNC_M = 0.04
DIM = 256
NEAR_VOXELS = 3.0  # "where both see": nearest neighbour in the other cloud within this many voxels

TARGET_SPEEDUP = 3.0
TARGET_RAYCAST_MS = 5.0
TARGET_MEDIAN_VOXELS = 0.5

REPO = Path(__file__).resolve().parents[2]
DEFAULT_DATA = Path("/work/shared/data/7scenes_redkitchen_300")
DEFAULT_SHARED = Path("/work/shared/data")


def die(msg, code=2):
    print(f"tsdf_vs_open3d: error: {msg}", file=sys.stderr)
    sys.exit(code)


def import_open3d():
    return o3d_import.import_np_o3d('tsdf_vs_open3d')[1]


# ----------------------------------------------------------------------------------------------
# Data set (FORMATS.md section 2: per-frame layout, camera.toml)


def read_camera(data):
    import tomllib
    toml = data / "camera.toml"
    if not toml.is_file():
        die(f"{toml} not found (expected the 7-Scenes per-frame layout of FORMATS.md section 2)")
    with open(toml, "rb") as f:
        cam = tomllib.load(f)
    for k in ("width", "height", "fx", "fy", "cx", "cy", "depth_scale"):
        if k not in cam:
            die(f"{toml}: missing '{k}'")
    cam.setdefault("min_range", 0.0)
    cam.setdefault("max_range", 65.535 * 1000.0 / cam["depth_scale"])
    return cam


def frame_paths(data, n):
    out = []
    for i in range(n):
        d = data / f"frame-{i:06d}.depth.png"
        p = data / f"frame-{i:06d}.pose.txt"
        if not d.is_file() or not p.is_file():
            die(f"{data}: frame {i} missing ({d.name} / {p.name}); --frames {n} needs frames 0..{n - 1}")
        out.append((d, p))
    return out


def load_frames(o3d, data, cam, n):
    """Depth images (uint16, raw) and camera-to-world poses; counts of special values."""
    import numpy as np
    depths, poses = [], []
    stats = {"pixels": 0, "zero": 0, "v65535": 0, "below_min": 0, "above_max": 0}
    lo = cam["min_range"] * cam["depth_scale"]
    hi = cam["max_range"] * cam["depth_scale"]
    for d, p in frame_paths(data, n):
        img = np.asarray(o3d.io.read_image(str(d)))
        if img.dtype != np.uint16 or img.shape != (cam["height"], cam["width"]):
            die(f"{d}: expected a {cam['width']}x{cam['height']} 16-bit PNG, got {img.dtype} {img.shape}")
        T = np.loadtxt(p)
        if T.shape != (4, 4) or not np.all(np.isfinite(T)):
            die(f"{p}: not a finite 4x4 matrix")
        stats["pixels"] += img.size
        stats["zero"] += int((img == 0).sum())
        stats["v65535"] += int((img == 65535).sum())
        stats["below_min"] += int(((img > 0) & (img < lo)).sum())
        stats["above_max"] += int(((img > hi) & (img != 65535)).sum())
        depths.append(img)
        poses.append(T)
    return depths, poses, stats


def mask_invalid(img, cam):
    """0 where the sensor has no valid measurement: 0, 65535 (7-Scenes' invalid), out of range.
    edgefuse applies the same range check (camera.toml min_range/max_range) per voxel."""
    import numpy as np
    lo = cam["min_range"] * cam["depth_scale"]
    hi = cam["max_range"] * cam["depth_scale"]
    out = img.copy()
    out[(img == 65535) | (img < lo) | (img > hi)] = 0
    return np.ascontiguousarray(out)


def volume_origin(depth, T, cam):
    """Minimum corner of a DIM^3 volume centred on the median of the first frame's points."""
    import numpy as np
    z = mask_invalid(depth, cam).astype(np.float64) / cam["depth_scale"]
    v, u = np.nonzero(z > 0)
    zz = z[v, u]
    if zz.size == 0:
        die("the first frame has no valid depth; cannot place the volume")
    pc = np.stack([(u - cam["cx"]) / cam["fx"] * zz, (v - cam["cy"]) / cam["fy"] * zz, zz], axis=1)
    pw = pc @ T[:3, :3].T + T[:3, 3]
    centre = np.median(pw, axis=0)
    return centre - 0.5 * DIM * VOXEL_M, centre


# ----------------------------------------------------------------------------------------------
# Open3D worker (child process; OMP_NUM_THREADS set by the parent)


def o3d_worker(args):
    o3d = import_open3d()
    import numpy as np
    data = Path(args.data)
    cam = read_camera(data)
    origin = np.array([float(x) for x in args.origin.split(",")], dtype=np.float64)
    depths, poses, _ = load_frames(o3d, data, cam, args.frames)
    intr = o3d.camera.PinholeCameraIntrinsic(cam["width"], cam["height"], cam["fx"], cam["fy"], cam["cx"],
                                             cam["cy"])
    black = o3d.geometry.Image(np.zeros((cam["height"], cam["width"], 3), np.uint8))
    # Preload: everything but `integrate` happens here.
    rgbds, extrinsics = [], []
    for img, T in zip(depths, poses):
        rgbds.append(o3d.geometry.RGBDImage.create_from_color_and_depth(
            black, o3d.geometry.Image(mask_invalid(img, cam)), depth_scale=float(cam["depth_scale"]),
            depth_trunc=float(cam["max_range"]), convert_rgb_to_intensity=False))
        extrinsics.append(np.ascontiguousarray(np.linalg.inv(T)))  # world-to-camera
    del depths
    vol = o3d.pipelines.integration.UniformTSDFVolume(
        length=DIM * VOXEL_M, resolution=DIM, sdf_trunc=TRUNC_M,
        color_type=o3d.pipelines.integration.TSDFVolumeColorType.NoColor, origin=origin)
    wall, cpu = [], []
    for rgbd, E in zip(rgbds, extrinsics):
        c0, t0 = time.process_time(), time.perf_counter()
        vol.integrate(rgbd, intr, E)
        t1, c1 = time.perf_counter(), time.process_time()
        wall.append((t1 - t0) * 1e3)
        cpu.append((c1 - c0) * 1e3)
    t0 = time.perf_counter()
    pc = vol.extract_point_cloud()
    extract_ms = (time.perf_counter() - t0) * 1e3
    o3d.io.write_point_cloud(args.o3d_out, pc, write_ascii=False)
    with open(args.o3d_json, "w") as f:
        json.dump({"wall_ms": wall, "cpu_ms": cpu, "points": len(pc.points), "extract_ms": extract_ms,
                   "omp_num_threads": os.environ.get("OMP_NUM_THREADS"), "open3d": o3d.__version__}, f)
    return 0


# ----------------------------------------------------------------------------------------------
# edgefuse runs

SUMMARY_RE = re.compile(r"^frames=(\d+) integrate_ms=([\d.]+) raycast_ms=([\d.]+) voxels=(\d+)\s*$", re.M)
FRAME_RE = re.compile(r"^frame (\d+)/(\d+) stamp [\d.]+: integrate ([\d.]+) ms, raycast ([\d.]+) ms, (\d+)% of pixels",
                      re.M)
CLOUD_RE = re.compile(r"^cloud: (\d+) points(.*?) -> ", re.M)
VOLUME_RE = re.compile(r"^volume: .*origin ([-\d.]+),([-\d.]+),([-\d.]+)", re.M)
HEADER_RE = re.compile(r", (\d+)x(\d+) fx ")


def find_edgefuse(given):
    if given:
        p = Path(given)
        if not (p.is_file() and os.access(p, os.X_OK)):
            die(f"--edgefuse {given}: not an executable file")
        return p
    for c in (REPO / "build/bench/tools/edgefuse", REPO / "build/host/tools/edgefuse",
              REPO / "build/dev/tools/edgefuse", Path("/tmp/lead/build/tools/edgefuse")):
        if c.is_file() and os.access(c, os.X_OK):
            try:  # skip cross-compiled binaries
                subprocess.run([str(c)], capture_output=True, timeout=10)
            except OSError:
                continue
            return c
    die("no edgefuse binary found; build it (cmake -S . -B build/bench -G Ninja -DCMAKE_BUILD_TYPE=Release && "
        "cmake --build build/bench --target edgefuse) or pass --edgefuse PATH")


class Contention:
    """Wall time, our child's CPU time and everybody else's CPU time (in cores) over a run."""

    def __enter__(self):
        import resource
        self.t0, self.b0 = time.perf_counter(), cpu_busy_s()
        ru = resource.getrusage(resource.RUSAGE_CHILDREN)
        self.c0 = ru.ru_utime + ru.ru_stime
        return self

    def __exit__(self, *exc):
        import resource
        self.wall_s = time.perf_counter() - self.t0
        ru = resource.getrusage(resource.RUSAGE_CHILDREN)
        self.child_cpu_s = ru.ru_utime + ru.ru_stime - self.c0
        self.other_cores = max(0.0, (cpu_busy_s() - self.b0 - self.child_cpu_s) / max(self.wall_s, 1e-9))
        return False

    def as_dict(self):
        return {"wall_s": self.wall_s, "child_cpu_s": self.child_cpu_s, "other_cores": self.other_cores}


def wait_quiet(max_wait_s, busy_cores=0.3):
    """Wait (up to max_wait_s) until the other processes use less than busy_cores cores."""
    if max_wait_s <= 0:
        return None
    t_end = time.time() + max_wait_s
    while True:
        b0 = cpu_busy_s()
        time.sleep(2.0)
        busy = (cpu_busy_s() - b0) / 2.0
        if busy < busy_cores or time.time() >= t_end:
            return busy
        time.sleep(3.0)


def git_state():
    try:
        head = subprocess.run(["git", "-C", str(REPO), "rev-parse", "--short", "HEAD"], capture_output=True,
                              text=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(REPO), "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True).stdout.splitlines()
        return f"repo HEAD {head or '?'}, {len(dirty)} tracked files modified"
    except OSError:
        return "git not available"


STALL_S = 300.0  # set from --stall-timeout


def run_edgefuse(exe, argv, log_path):
    """Runs `edgefuse fuse`, line-buffered (stdbuf) so that a run which stops printing progress for
    STALL_S seconds is recognised as hung, killed and reported with the last frame it reached."""
    import threading
    cmd = [str(exe), "fuse"] + [str(a) for a in argv]
    stdbuf = shutil.which("stdbuf")
    full = ([stdbuf, "-oL"] if stdbuf else []) + cmd
    load0 = os.getloadavg()[0]
    lines, last = [], [time.monotonic()]

    def reader(stream):
        for line in stream:
            lines.append(line)
            last[0] = time.monotonic()

    with Contention() as cont:
        proc = subprocess.Popen(full, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        th = threading.Thread(target=reader, args=(proc.stdout,), daemon=True)
        th.start()
        hung = False
        while proc.poll() is None:
            time.sleep(1.0)
            if time.monotonic() - last[0] > STALL_S:
                hung = True
                proc.kill()
                proc.wait()
        th.join(timeout=10)
    wall_s = cont.wall_s
    out_text = "".join(lines)
    Path(log_path).write_text("$ " + " ".join(cmd) + "\n" + out_text)
    if hung:
        prog = [l.strip() for l in lines if l.startswith("frame ")]
        die(f"edgefuse printed nothing for {STALL_S:.0f} s and was killed (hung?) after "
            f"'{prog[-1] if prog else (lines[-1].strip() if lines else 'no output')}' "
            f"({'progress lines come every 10 frames' if prog else ''}): {' '.join(cmd)} (log: {log_path})", 3)
    if proc.returncode != 0:
        die(f"edgefuse failed (exit {proc.returncode}): {' '.join(cmd)}\n{out_text.strip()[-2000:]}", 1)
    r = subprocess.CompletedProcess(cmd, proc.returncode, out_text, "")
    m = SUMMARY_RE.search(r.stdout)
    if not m:
        die(f"no 'frames=... integrate_ms=...' line in the output of {' '.join(cmd)} (see {log_path})", 1)
    frames = [(int(a), float(b), float(c), int(d)) for a, _, b, c, d in FRAME_RE.findall(r.stdout)]
    cm = CLOUD_RE.search(r.stdout)
    vm = VOLUME_RE.search(r.stdout)
    hm = HEADER_RE.search(r.stdout)
    return {
        "cmd": " ".join(cmd), "frames": int(m.group(1)), "integrate_ms": float(m.group(2)),
        "raycast_ms": float(m.group(3)), "voxels": int(m.group(4)), "sampled": frames,
        "points": int(cm.group(1)) if cm else None, "truncated": bool(cm and "truncated" in cm.group(2)),
        "origin": [float(vm.group(i)) for i in (1, 2, 3)] if vm else None,
        "resolution": f"{hm.group(1)}x{hm.group(2)}" if hm else "?", "wall_s": wall_s,
        "load": (load0, os.getloadavg()[0]), "contention": cont.as_dict(),
    }


# ----------------------------------------------------------------------------------------------
# Cloud comparison


def pct(a, q):
    import numpy as np
    return float(np.percentile(a, q)) if len(a) else float("nan")


def edge_keys(P, origin):
    """Grid edge of each zero-crossing point: (axis, lower voxel index). Points of both clouds lie on
    the edges between voxel centres origin + (i + 0.5) * voxel."""
    import numpy as np
    g = (P - origin) / VOXEL_M - 0.5
    r = np.abs(g - np.round(g))
    axis = np.argmax(r, axis=1)
    off = np.sort(r, axis=1)[:, 1]  # second-largest distance to the grid = off-edge error
    idx = np.round(g).astype(np.int64)
    rows = np.arange(len(P))
    idx[rows, axis] = np.floor(g[rows, axis]).astype(np.int64)
    idx = np.clip(idx + 1, 0, 1023)
    keys = ((axis.astype(np.int64) * 1024 + idx[:, 0]) * 1024 + idx[:, 1]) * 1024 + idx[:, 2]
    return keys, axis, g, off


def compare_clouds(o3d, ef_path, o3_path, origin):
    import numpy as np
    ef = o3d.io.read_point_cloud(str(ef_path))
    o3 = o3d.io.read_point_cloud(str(o3_path))
    near = NEAR_VOXELS * VOXEL_M
    res = {"ef_points": len(ef.points), "o3_points": len(o3.points)}
    for name, a, b in (("ef_to_o3", ef, o3), ("o3_to_ef", o3, ef)):
        d = np.asarray(a.compute_point_cloud_distance(b))
        inside = d[d <= near]
        res[name] = {"n": int(d.size), "excluded_share": float(1.0 - inside.size / max(d.size, 1)),
                     "median": pct(inside, 50), "p95": pct(inside, 95),
                     "median_all": pct(d, 50), "p95_all": pct(d, 95), "max_all": float(d.max()) if d.size else 0.0}
    # Per grid edge.
    Pe, Po = np.asarray(ef.points, np.float64), np.asarray(o3.points, np.float64)
    ke, ae, ge, offe = edge_keys(Pe, origin)
    ko, ao, go, offo = edge_keys(Po, origin)
    common, ie, io = np.intersect1d(ke, ko, assume_unique=False, return_indices=True)
    ax = ae[ie]
    shift = (ge[ie, ax] - go[io, ax]) * VOXEL_M  # edgefuse minus Open3D, along the edge axis
    edge = {"off_grid_max_voxels": float(max(offe.max() if offe.size else 0, offo.max() if offo.size else 0)),
            "common": int(common.size), "ef_share": common.size / max(len(ke), 1),
            "o3_share": common.size / max(len(ko), 1)}
    if common.size:
        Ne, No = np.asarray(ef.normals), np.asarray(o3.normals)
        if len(Ne) == len(Pe) and len(No) == len(Po):
            dots = np.sum(Ne[ie] * No[io], axis=1)
            # Sign along the surface normal (Open3D's normal = TSDF gradient, towards free space):
            # positive = edgefuse's surface lies on the free-space (camera) side of Open3D's.
            signed = shift * np.sign(No[io, ax])
            edge.update({"normal_dot_median": float(np.median(dots)), "normal_dot_neg_share": float((dots < 0).mean()),
                         "signed_median": float(np.median(signed)), "signed_mean": float(signed.mean()),
                         "signed_per_axis": [float(np.median(signed[ax == k])) if (ax == k).any() else float("nan")
                                             for k in range(3)]})
        edge.update({"abs_median": float(np.median(np.abs(shift))), "abs_p95": pct(np.abs(shift), 95)})
    res["edges"] = edge
    return res


def identical_clouds(o3d, a, b):
    import numpy as np
    A = np.asarray(o3d.io.read_point_cloud(str(a)).points)
    B = np.asarray(o3d.io.read_point_cloud(str(b)).points)
    if A.shape != B.shape:
        return f"different point counts ({len(A)} vs {len(B)})"
    A, B = A[np.lexsort(A.T)], B[np.lexsort(B.T)]
    diff = float(np.abs(A - B).max()) if len(A) else 0.0
    return "identical" if diff == 0 else f"same count, max coordinate difference {diff:.2e} m"


# ----------------------------------------------------------------------------------------------
# PLY compatibility


def check_ply_readers(o3d, ply, expected_points):
    import numpy as np
    out = {}
    pc = o3d.io.read_point_cloud(str(ply))
    P = np.asarray(pc.points)
    ok = len(P) == expected_points and len(P) > 0 and np.all(np.isfinite(P))
    out["open3d"] = (f"{'OK' if ok else 'FAIL'}: o3d.io.read_point_cloud read {len(P)} points (edgefuse wrote "
                     f"{expected_points}), normals={'yes' if pc.has_normals() else 'no'}, "
                     f"colours={'yes' if pc.has_colors() else 'no'}, all finite={bool(np.all(np.isfinite(P)))}")
    with open(ply, "rb") as f:
        head = f.read(1024).split(b"end_header")[0].decode("ascii", "replace")
    out["header"] = " | ".join(l for l in head.splitlines() if l and not l.startswith("comment"))
    exe = shutil.which("pcl_ply2pcd")
    if exe is None:
        out["pcl"] = "skipped: pcl_ply2pcd not installed (apt-get install pcl-tools)"
    else:
        pcd = Path(ply).with_suffix(".pcl.pcd")
        r = subprocess.run([exe, str(ply), str(pcd)], capture_output=True, text=True)
        txt = r.stdout + r.stderr
        m = re.search(r"Loading .*?: (\d+) points", txt)
        dims = re.search(r"Available dimensions: (.*)", txt)
        n = int(m.group(1)) if m else -1
        ok = r.returncode == 0 and n == expected_points and pcd.is_file()
        out["pcl"] = (f"{'OK' if ok else 'FAIL'}: pcl_ply2pcd (PCL {pcl_version()}) exit {r.returncode}, "
                      f"{n} points, fields: {dims.group(1).strip() if dims else '?'}")
    return out


def pcl_version():
    try:
        r = subprocess.run(["dpkg-query", "-W", "-f=${Version}", "pcl-tools"], capture_output=True, text=True)
        return r.stdout.strip() or "?"
    except OSError:
        return "?"


# ----------------------------------------------------------------------------------------------


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=300, help="frames to fuse (default 300)")
    ap.add_argument("--threads", default="2",
                    help="thread count(s), comma-separated: edgefuse --threads N and OMP_NUM_THREADS=N for Open3D "
                         "(default 2; e.g. 2,1 runs both)")
    ap.add_argument("--edgefuse", help="edgefuse binary (default: build/bench/tools/edgefuse, then other host builds)")
    ap.add_argument("--out", default="/tmp/edgefuse_bench", help="directory for clouds, logs, summary.json "
                                                                  "(default /tmp/edgefuse_bench; not the repo)")
    ap.add_argument("--data", default=str(DEFAULT_DATA), help="7-Scenes per-frame folder")
    ap.add_argument("--shared", default=str(DEFAULT_SHARED), help="folder with bin_rig_a and tum_fr1_xyz_37")
    ap.add_argument("--no-raycast", action="store_true", help="skip the raycast figure block")
    ap.add_argument("--stall-timeout", type=float, default=300.0, metavar="S",
                    help="kill and report an edgefuse run that prints no progress for S seconds (default 300)")
    ap.add_argument("--volume-origin", metavar="X,Y,Z",
                    help="override the volume's minimum corner (default: centred on the median of frame 0's points)")
    ap.add_argument("--wait-quiet", type=float, default=0, metavar="S",
                    help="before each timed run wait up to S seconds for other processes to use < 0.3 cores "
                         "(default 0: don't wait)")
    # internal: Open3D child process
    ap.add_argument("--o3d-worker", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--origin", help=argparse.SUPPRESS)
    ap.add_argument("--o3d-out", help=argparse.SUPPRESS)
    ap.add_argument("--o3d-json", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.frames < 1:
        die("--frames must be >= 1")
    if args.o3d_worker:
        return o3d_worker(args)
    global STALL_S
    STALL_S = args.stall_timeout

    try:
        threads = [int(t) for t in args.threads.split(",")]
        assert all(t >= 1 for t in threads)
    except (ValueError, AssertionError):
        die(f"--threads: expected positive integers separated by commas, got '{args.threads}'")
    data = Path(args.data)
    if not data.is_dir():
        die(f"data set {data} not found")
    o3d = import_open3d()
    import numpy as np
    exe = find_edgefuse(args.edgefuse)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    shared = Path(args.shared)
    if not args.no_raycast:
        for sub in ("bin_rig_a", "tum_fr1_xyz_37"):
            if not (shared / sub).is_dir():
                die(f"{shared / sub} not found (needed for the raycast block; --no-raycast skips it)")

    cam = read_camera(data)
    depths, poses, st = load_frames(o3d, data, cam, args.frames)
    origin, centre = volume_origin(depths[0], poses[0], cam)
    origin_note = f"centre = median of frame 0's points {centre[0]:.4f},{centre[1]:.4f},{centre[2]:.4f}"
    if args.volume_origin:
        try:
            given = np.array([float(x) for x in args.volume_origin.split(",")], dtype=np.float64)
            assert given.shape == (3,) and np.all(np.isfinite(given))
        except (ValueError, AssertionError):
            die(f"--volume-origin: expected X,Y,Z, got '{args.volume_origin}'")
        origin_note = (f"given by --volume-origin; the default would be "
                       f"{','.join(f'{x:.6f}' for x in origin)}")
        origin = given
    del depths
    origin_s = ",".join(f"{x:.6f}" for x in origin)

    print(f"== host: {os.cpu_count()} CPUs, load average {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    print(f"== edgefuse vs Open3D {o3d.__version__} UniformTSDFVolume, {data.name}, {args.frames} frames, "
          f"{cam['width']}x{cam['height']}")
    print(f"edgefuse: {exe} (built {time.strftime('%Y-%m-%d %H:%M', time.localtime(exe.stat().st_mtime))}; "
          f"{git_state() if REPO in exe.resolve().parents else 'not built from this checkout'})")
    print(f"volume: {DIM}^3 x {VOXEL_M} m, trunc {TRUNC_M} m, origin {origin_s} ({origin_note})")
    px = st["pixels"]
    print(f"depth: {st['zero'] / px:.2%} zero, {st['v65535']} pixels = 65535, {st['below_min']} below min_range "
          f"{cam['min_range']} m, {st['above_max']} above max_range {cam['max_range']} m; all masked to 0 for Open3D, "
          f"depth_trunc={cam['max_range']}")
    sys.stdout.flush()

    results = {"data": str(data), "frames": args.frames, "origin": origin.tolist(), "edgefuse": str(exe),
               "depth_stats": st, "runs": {}}
    for t in threads:
        ef_ply = out / f"edgefuse_7scenes_t{t}.ply"
        wait_quiet(args.wait_quiet)
        ef = run_edgefuse(exe, [data, "--frames", args.frames, "--voxel", VOXEL_M, "--trunc", TRUNC_M, "--volume", DIM,
                                "--origin", origin_s, "--threads", t, "--out", ef_ply],
                          out / f"edgefuse_7scenes_t{t}.log")
        if ef["frames"] != args.frames:
            die(f"edgefuse fused {ef['frames']} frames, expected {args.frames}", 1)
        if ef["origin"] and max(abs(a - b) for a, b in zip(ef["origin"], origin)) > 1e-3:
            die(f"edgefuse reports origin {ef['origin']}, expected {origin_s}", 1)
        o3_ply = out / f"open3d_7scenes_t{t}.ply"
        o3_json = out / f"open3d_7scenes_t{t}.json"
        env = dict(os.environ, OMP_NUM_THREADS=str(t))
        wait_quiet(args.wait_quiet)
        load0 = os.getloadavg()[0]
        with Contention() as cont:
            r = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--o3d-worker", "--data", str(data),
                            "--frames", str(args.frames), f"--origin={origin_s}", "--o3d-out", str(o3_ply),
                                "--o3d-json", str(o3_json)], env=env)
        if r.returncode != 0:
            die(f"Open3D worker failed (exit {r.returncode})", 1)
        o3 = json.loads(o3_json.read_text())
        o3["wall_s"] = cont.wall_s
        o3["contention"] = cont.as_dict()
        o3["load"] = (load0, os.getloadavg()[0])
        cmp = compare_clouds(o3d, ef_ply, o3_ply, origin)
        results["runs"][t] = {"edgefuse": ef, "open3d": {k: v for k, v in o3.items()}, "compare": cmp}
        report_run(t, ef, o3, cmp)

    if len(threads) > 1:
        a, b = threads[0], threads[1]
        print(f"-- determinism: edgefuse t{a} vs t{b} clouds: "
              f"{identical_clouds(o3d, out / f'edgefuse_7scenes_t{a}.ply', out / f'edgefuse_7scenes_t{b}.ply')}; "
              f"Open3D: {identical_clouds(o3d, out / f'open3d_7scenes_t{a}.ply', out / f'open3d_7scenes_t{b}.ply')}")

    ray = {}
    if not args.no_raycast:
        print("\n== edgefuse raycast (board defaults for voxel/trunc/volume; raycast_ms = mean per frame of a full "
              "raycast of the sensor view)")
        for key, ds, extra, t in (("bin_rig_a/xtion t1", "bin_rig_a", ["--sensor", "xtion"], 1),
                                  ("tum_fr1_xyz_37 t1", "tum_fr1_xyz_37", [], 1),
                                  ("tum_fr1_xyz_37 t2", "tum_fr1_xyz_37", [], 2)):
            tag = key.replace("/", "_").replace(" ", "_")
            wait_quiet(args.wait_quiet)
            r = run_edgefuse(exe, [shared / ds] + extra + ["--threads", t, "--out", out / f"raycast_{tag}.ply"],
                             out / f"raycast_{tag}.log")
            ray[key] = r
            rc = [s[2] for s in r["sampled"]]
            print(f"{key:20s} {r['resolution']:>8s}: raycast_ms={r['raycast_ms']:.2f} (mean of {r['frames']} frames; "
                  f"sampled frames min {min(rc):.2f} max {max(rc):.2f}), integrate_ms={r['integrate_ms']:.2f}, "
                  f"hit {r['sampled'][-1][3]}% (last frame); other processes {r['contention']['other_cores']:.2f} "
                  f"cores\n    [{r['cmd']}]")
        for key in ("bin_rig_a/xtion t1", "tum_fr1_xyz_37 t1"):
            c = ray[key]["contention"]
            share = c["child_cpu_s"] / max(c["wall_s"], 1e-9)
            print(f"  CPU-time view {key}: raycast ~{ray[key]['raycast_ms'] * share:.2f} ms/frame (raycast_ms x core "
                  f"share {share:.2f}; other processes {c['other_cores']:.2f} cores)")
        tum1 = ray["tum_fr1_xyz_37 t1"]["raycast_ms"]
        print(f"  (tum 640x480 on one core / 4 = {tum1 / 4:.2f} ms: a pixel-count estimate for 320x240, not a "
              f"measurement)")
    results["raycast"] = ray

    print("\n== edgefuse PLY readability")
    t0 = threads[0]
    plys = [(f"edgefuse_7scenes_t{t0}.ply", results["runs"][t0]["edgefuse"]["points"])]
    if ray:  # TUM has registered colour: a PLY with red/green/blue too
        plys.append(("raycast_tum_fr1_xyz_37_t1.ply", ray["tum_fr1_xyz_37 t1"]["points"]))
    results["ply_check"] = {}
    for name, n in plys:
        chk = check_ply_readers(o3d, out / name, n)
        print(name)
        for k, v in chk.items():
            print(f"  {k}: {v}")
        results["ply_check"][name] = chk

    print("\n== targets")
    verdicts = []
    for t in threads:
        run = results["runs"][t]
        ratio = mean(run["open3d"]["wall_ms"]) / run["edgefuse"]["integrate_ms"]
        verdicts.append((f"integration >= {TARGET_SPEEDUP:g}x faster than Open3D ({t} thread{'s' if t > 1 else ''})",
                         ratio >= TARGET_SPEEDUP, f"{ratio:.2f}x"))
    if ray:
        rc = ray["bin_rig_a/xtion t1"]["raycast_ms"]
        verdicts.append((f"320x240 raycast < {TARGET_RAYCAST_MS:g} ms on one core", rc < TARGET_RAYCAST_MS,
                         f"{rc:.2f} ms"))
    c = results["runs"][t0]["compare"]
    worst = max(c["ef_to_o3"]["median"], c["o3_to_ef"]["median"])
    verdicts.append((f"median cloud distance <= {TARGET_MEDIAN_VOXELS:g} voxel where both see",
                     worst <= TARGET_MEDIAN_VOXELS * VOXEL_M,
                     f"{c['ef_to_o3']['median'] * 1e3:.2f} / {c['o3_to_ef']['median'] * 1e3:.2f} mm"))
    for name, ok, val in verdicts:
        print(f"{'MET    ' if ok else 'NOT MET'}  {name}: {val}")
    results["targets"] = [{"target": n, "met": ok, "value": v} for n, ok, v in verdicts]
    (out / "summary.json").write_text(json.dumps(results, indent=1, default=str))
    print(f"\nclouds, logs and summary.json in {out}")
    return 0


def mean(a):
    return sum(a) / len(a)


def contention_text(c):
    return (f"whole process: wall {c['wall_s']:.0f} s, its CPU {c['child_cpu_s']:.0f} s, other processes used "
            f"{c['other_cores']:.2f} of {os.cpu_count()} cores")


def report_run(t, ef, o3, cmp):
    import numpy as np
    w = np.array(o3["wall_ms"])
    cpu = np.array(o3["cpu_ms"])
    efi = [s[1] for s in ef["sampled"]]
    print(f"\n-- {t} thread{'s' if t > 1 else ''} (edgefuse --threads {t}, Open3D OMP_NUM_THREADS={t})")
    print(f"edgefuse integrate: {ef['integrate_ms']:.1f} ms/frame mean (its integrate_ms); sampled frames "
          f"(1,10,20,..) median {np.median(efi):.1f}, min {min(efi):.1f}, max {max(efi):.1f}; raycast 640x480 "
          f"{ef['raycast_ms']:.1f} ms/frame; {contention_text(ef['contention'])}")
    print(f"Open3D   integrate: {w.mean():.1f} ms/frame mean; median {np.median(w):.1f}, min {w.min():.1f}, "
          f"max {w.max():.1f}, p95 {np.percentile(w, 95):.1f}; CPU time in integrate {cpu.mean():.1f} ms/frame "
          f"(CPU/wall {cpu.sum() / w.sum():.2f}); {contention_text(o3['contention'])}")
    print(f"ratio Open3D/edgefuse: {w.mean() / ef['integrate_ms']:.2f}x (means), "
          f"{np.median(w) / np.median(efi):.2f}x (medians)")
    if t == 1:
        # One thread: the share of a core each process got (its CPU / its wall) turns wall time into an
        # estimate of CPU time, which contention inflates much less. Open3D's is measured per call.
        share = ef["contention"]["child_cpu_s"] / max(ef["contention"]["wall_s"], 1e-9)
        print(f"CPU-time view (1 thread): Open3D {cpu.mean():.1f} ms/frame (measured), edgefuse ~"
              f"{ef['integrate_ms'] * share:.1f} ms/frame (integrate_ms x its core share {share:.2f}), ratio ~"
              f"{cpu.mean() / (ef['integrate_ms'] * share):.2f}x")
    if ef["contention"]["other_cores"] > 0.3 or o3["contention"]["other_cores"] > 0.3:
        print(f"WARNING: other processes kept {max(ef['contention']['other_cores'], o3['contention']['other_cores']):.1f}"
              f" of {os.cpu_count()} cores busy during these runs: wall times are inflated and thread scaling is "
              f"not meaningful")
    print(f"clouds: edgefuse {cmp['ef_points']} points{' (TRUNCATED at board capacity)' if ef['truncated'] else ''}, "
          f"Open3D {cmp['o3_points']} points; observed voxels (edgefuse) {ef['voxels']}")
    for name, label in (("ef_to_o3", "edgefuse -> Open3D"), ("o3_to_ef", "Open3D -> edgefuse")):
        d = cmp[name]
        print(f"{label}: where both see (NN <= {NEAR_VOXELS:g} voxels): median {d['median'] * 1e3:.2f} mm, "
              f"p95 {d['p95'] * 1e3:.2f} mm; excluded {d['excluded_share']:.1%}; "
              f"all points: median {d['median_all'] * 1e3:.2f} mm, p95 {d['p95_all'] * 1e3:.2f} mm, "
              f"max {d['max_all'] * 1e3:.1f} mm")
    e = cmp["edges"]
    line = (f"same grid edge: {e['common']} crossings on edges of both ({e['ef_share']:.1%} of edgefuse's, "
            f"{e['o3_share']:.1%} of Open3D's); |shift| median {e.get('abs_median', float('nan')) * 1e3:.2f} mm, "
            f"p95 {e.get('abs_p95', float('nan')) * 1e3:.2f} mm")
    if "signed_median" in e:
        sx, sy, sz = (v * 1e3 for v in e["signed_per_axis"])
        line += (f"; signed (edgefuse - Open3D along Open3D's normal, + = edgefuse towards free space) median "
                 f"{e['signed_median'] * 1e3:+.2f} mm, mean {e['signed_mean'] * 1e3:+.2f} mm "
                 f"(x/y/z edges {sx:+.2f}/{sy:+.2f}/{sz:+.2f}); normals: median dot {e['normal_dot_median']:.3f}, "
                 f"{e['normal_dot_neg_share']:.1%} opposite")
    print(line)
    sys.stdout.flush()


if __name__ == "__main__":
    sys.exit(main())
