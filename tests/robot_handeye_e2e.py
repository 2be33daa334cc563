#!/usr/bin/python3
"""End-to-end: hand-eye calibration without a target, online. edgefused (host-sim,
sim backend) moves its rig along board/host-sim/handeye_stations.txt (sensors.sim_path: stations
tilted 15-25 deg about different horizontal axes, rolled about the viewing axis, eased moves
between them at ~1 deg a frame) and tracks it by ICP alone (tracking.poses = icp,
tracking.sim_truth = false: no hand-eye and no truth; tracking.push_every_frame = true).
tools/robot/robot_sim.py --handeye is the robot: CAPTURE, a POSE stream, HANDEYE ADD at every
station, HANDEYE SOLVE, and the solved T_flange_camera against its own mounting. Two runs: exact
robot poses, then 0.2 mm / 0.02 deg of error per reported pose. Checks: every station of the path
added; the stations' RMS residual within the robot's error plus the tracking's (TRACKING_MM /
TRACKING_DEG); the error within the hand-eye targets, 0.5 mm / 0.05 deg exact, 1 mm / 0.1 deg with
the robot's error (a run that misses it is repeated once, see RUNS); after HANDEYE SAVE,
CALIBRATION returns the solved mounting.

usage: robot_handeye_e2e.py [--emulator CMD] [--time-factor F] EDGEFUSED WORKDIR
"""
import json
import os
import signal
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tools", "robot"))
from edgefused_helpers import check, check_started, emulation, failures, popen, wait_started  # noqa: E402

EMU, SLOW = emulation(sys.argv)
EDGEFUSED, WORK = sys.argv[1:3]
ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
ROBOT_SIM = os.path.join(ROOT, "tools", "robot", "robot_sim.py")
BOARD = os.path.join(ROOT, "board", "host-sim", "edgefused.toml")
STATIONS = os.path.join(ROOT, "board", "host-sim", "handeye_stations.txt")
# the hand-eye targets per run. The stations' RMS residual is the robot's error per pose plus the
# tracking's: 0.09-0.12 mm / 0.009-0.012 deg measured with exact poses on this path, so 0.35 mm /
# 0.035 deg above the robot's error (3x) means tracking slipped; integrating only after 1 cm / 1 deg
# (tracking.push_every_frame = false) left the first station 0.24 deg off the others (an RMS of 0.1
# deg): the map then holds one noisy frame of each hold instead of their average.
RUNS = (("exact", "0", "0", 0.5, 0.05), ("noisy", "0.2", "0.02", 1.0, 0.1))
# A run missing its target is repeated once: the solved translation scatters ~0.15 mm per axis
# between runs of the same path (ICP) around a mean 0.2 mm forward along the camera's axis (the
# TSDF surface lies in front of the depth data: 0.8-0.9 mm with 3 mm voxels), so now and then an
# exact run lands above 0.5 mm (1 of 15 measured, 0.55 mm: docs/BENCHMARKS.md); two in a row fail.
TRACKING_MM, TRACKING_DEG = 0.35, 0.035


def run(name, error_mm, error_deg, save, folder=None):
    """One edgefused run driven by robot_sim --handeye; returns robot_sim's summary (or None)."""
    work = os.path.join(WORK, folder or name)
    os.makedirs(work, exist_ok=True)
    log_path = os.path.join(work, "edgefused.log")
    log = open(log_path, "w+")
    d = popen([*EMU, EDGEFUSED, "--board", "host-sim", "--config", BOARD, "--set", "sensors.sim_path=" + STATIONS,
               "--set", "link.tcp_port=0", "--set", "robot.text_port=0", "--set", "link.serial=", "--set", "console.serial=",
               "--set", "tracking.poses=icp", "--set", "tracking.sim_truth=false", "--set", "tracking.push_every_frame=true",
               "--set", "calib.dir=" + os.path.join(work, "state")], stdout=log, stderr=subprocess.STDOUT)
    info = wait_started(d, log, 30)
    if not check_started(d, log, info, ("robot",), "%s: edgefused started" % name):
        return None
    summary_path = os.path.join(work, "summary.json")
    cmd = ["/usr/bin/python3", ROBOT_SIM, "--port", info["robot"].rsplit(":", 1)[1], "--handeye", STATIONS,
           "--log", log_path, "--error-mm", error_mm, "--error-deg", error_deg, "--summary", summary_path]
    if save:
        cmd.append("--save")
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=120 * SLOW)
    print(r.stdout + r.stderr, flush=True)
    d.send_signal(signal.SIGTERM)
    d.wait(timeout=20 * SLOW)
    check(d.returncode == 0, "%s: SIGTERM stops edgefused cleanly" % name)
    if not os.path.exists(summary_path):
        check(False, "%s: robot_sim solved the hand-eye (exit %d)" % (name, r.returncode))
        return None
    with open(summary_path) as f:
        return json.load(f)


def missed(s, max_mm, max_deg):
    return s is not None and (s["error_mm_result"] > max_mm or s["error_deg_result"] > max_deg)


os.makedirs(WORK, exist_ok=True)
for name, e_mm, e_deg, max_mm, max_deg in RUNS:
    s = run(name, e_mm, e_deg, save=name == "exact")
    if missed(s, max_mm, max_deg):
        print("%s: %.3f mm / %.4f deg misses %g mm / %g deg; once more (see RUNS)" %
              (name, s["error_mm_result"], s["error_deg_result"], max_mm, max_deg), flush=True)
        s = run(name, e_mm, e_deg, save=name == "exact", folder=name + "-again")
    if s is None:
        continue
    check(s.get("stations", 0) == s.get("stations_path", -1),
          "%s: %d stations added (of %d on the path)" % (name, s.get("stations", 0), s.get("stations_path", 0)))
    max_res_mm, max_res_deg = float(e_mm) + TRACKING_MM, float(e_deg) + TRACKING_DEG
    check(s["residual_mm"] <= max_res_mm and s["residual_deg"] <= max_res_deg,
          "%s: station residual %.3f mm / %.4f deg RMS <= %g mm / %g deg" % (name, s["residual_mm"], s["residual_deg"],
                                                                           max_res_mm, max_res_deg))
    check(s["error_mm_result"] <= max_mm and s["error_deg_result"] <= max_deg,
          "%s: hand-eye error %.3f mm / %.4f deg <= %g mm / %g deg" % (name, s["error_mm_result"], s["error_deg_result"],
                                                                     max_mm, max_deg))
    if name == "exact":
        check(s.get("saved") is True, "exact: HANDEYE SAVE, then CALIBRATION returns the solved mounting")
print("FAILED: %d checks" % len(failures) if failures else "all checks passed")
sys.exit(1 if failures else 0)
