#!/usr/bin/env python3
"""Per-frame time split of `edgefuse track`: filter, raycast, ICP, integrate and the
whole loop, at 320x240 (bin_rig_a xtion, 256^3 x 2 mm) and 640x480 (TUM fr1/xyz, 256^3 x 1 cm), with
1 and 2 threads, for the float build (build/host) and the fixed-point build (build/host-fixed).

For every run it prints track's own wall-clock split (`frames=...` line) and its process-CPU split
(`cpu ...` line: CPU time of all threads, which on a shared machine is the better one-core figure),
and how many cores other processes kept busy during the run. It ends with one table.

usage: tools/bench/track_split.py [--builds host,host-fixed] [--threads 1,2] [--datasets xtion,tum]
                                  [--frames N] [--data DIR] [--out DIR]
"""
import argparse
import os
import re
import subprocess
import sys
import time
from pathlib import Path
from cpu_load import cpu_busy_s, child_cpu_s  # beside this script

REPO = Path(__file__).resolve().parents[2]
KV = re.compile(r"([A-Za-z_]+)=([-0-9.]+)")

DATASETS = {
    # key: (label, resolution, folder, extra track arguments)
    "xtion": ("bin_rig_a xtion", "320x240", "bin_rig_a", ["--sensor", "xtion"]),
    "tum": ("TUM fr1/xyz", "640x480", "tum_fr1_xyz_37", ["--voxel", "0.01"]),
}


def run(binary, ds, threads, frames, data, out):
    label, res, folder, extra = DATASETS[ds]
    cmd = [str(binary), "track", str(Path(data) / folder), *extra, "--threads", str(threads),
           "--out", str(Path(out) / f"{binary.parent.parent.name}_{ds}_t{threads}.txt")]
    if frames:
        cmd += ["--frames", str(frames)]
    b0, c0, t0 = cpu_busy_s(), child_cpu_s(), time.time()
    r = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.time() - t0
    own = child_cpu_s() - c0
    other = max(0.0, (cpu_busy_s() - b0 - own) / max(wall, 1e-9))
    if r.returncode != 0:
        sys.exit(f"track_split: {' '.join(cmd)} failed ({r.returncode}): {r.stderr.strip()[-400:]}")
    wall_line = next((l for l in r.stdout.splitlines() if l.startswith("frames=")), "")
    cpu_line = next((l for l in r.stdout.splitlines() if l.startswith("cpu ")), "")
    if not wall_line or not cpu_line:
        sys.exit(f"track_split: {' '.join(cmd)}: no summary lines (a track without the cpu line?)")
    return {"cmd": " ".join(cmd), "label": label, "res": res, "wall": dict((k, float(v)) for k, v in KV.findall(wall_line)),
            "cpu": dict((k, float(v)) for k, v in KV.findall(cpu_line)), "other": other, "wall_line": wall_line,
            "cpu_line": cpu_line}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--builds", default="host,host-fixed", help="build folders under build/ (default host,host-fixed)")
    ap.add_argument("--threads", default="1,2")
    ap.add_argument("--datasets", default="xtion,tum", help="subset of xtion,tum")
    ap.add_argument("--frames", type=int, default=0, help="first N frames only (default all)")
    ap.add_argument("--data", default=str(REPO.parent / "shared" / "data"))
    ap.add_argument("--out", default="/tmp/edgefuse_track_split", help="trajectories (never the repo)")
    a = ap.parse_args()
    Path(a.out).mkdir(parents=True, exist_ok=True)
    for ds in a.datasets.split(","):
        if ds not in DATASETS:
            sys.exit(f"track_split: unknown data set {ds!r} (xtion, tum)")
        if not (Path(a.data) / DATASETS[ds][2]).is_dir():
            print(f"track_split: {Path(a.data) / DATASETS[ds][2]} missing", file=sys.stderr)
            return 2
    rows = []
    print(f"== host: {os.cpu_count()} CPUs, load average {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    for build in a.builds.split(","):
        binary = REPO / "build" / build / "tools" / "edgefuse"
        if not binary.exists():
            print(f"track_split: {binary} missing (cmake --preset {build} && cmake --build build/{build})",
                  file=sys.stderr)
            return 2
        for ds in a.datasets.split(","):
            for t in a.threads.split(","):
                r = run(binary, ds, int(t), a.frames, a.data, a.out)
                r["build"], r["threads"] = build, int(t)
                print(f"[{r['cmd']}]\n  {r['wall_line']}\n  {r['cpu_line']}\n  other processes: {r['other']:.2f} cores")
                rows.append(r)
    print("\nper frame, ms: CPU time of the process (all threads) / wall clock; fps from the CPU loop time")
    print("| build | data | res | threads | filter | raycast | ICP | integrate | loop | fps (CPU) | fps (wall) | other cores |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        c, w = r["cpu"], r["wall"]
        cell = lambda k: f"{c[k]:.1f} / {w[k]:.1f}"
        print(f"| {r['build']} | {r['label']} | {r['res']} | {r['threads']} | {cell('filter_ms')} | {cell('raycast_ms')} | "
              f"{cell('icp_ms')} | {cell('integrate_ms')} | {cell('loop_ms')} | {c['fps']:.1f} | {w['fps']:.1f} | "
              f"{r['other']:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
