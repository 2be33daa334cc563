#!/usr/bin/python3
"""End-to-end: the simulated robot cell on loopback. edgefused (host-sim) replays a rig set with
tracking.poses = robot and then robot+icp, never with the set's truth (tracking.sim_truth = false);
tools/robot/robot_sim.py is the robot controller (its hand-eye mounting over the console, CAPTURE,
250 Hz POSE stream with 0.5-1 mm / 0.05-0.1 deg error per update and 10 ms latency, DETECT, NEXT
until NO_OBJECTS, PICKED OK). Checks, in the robot's base frame (the set's world frame): robot+icp
delivers at least 5 of the 6 objects, each within 5 mm / 10 deg, median <= 1.5 mm / 1.5 deg; it is
no worse than robot alone; every frame had a robot pose; the replay's time base starts within 50 ms
of the CAPTURE reply the robot's motion starts with. robot+icp runs once more when the localiser
misses more than one object (it takes a bin wall for boxes now and then, whatever the poses).

usage: robot_cell_e2e.py [--emulator CMD] [--time-factor F] EDGEFUSED EDGEFUSE DATA WORKDIR
"""
import json
import os
import signal
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from edgefused_helpers import emulation, popen, wait_started  # noqa: E402

EMU, SLOW = emulation(sys.argv)
EDGEFUSED, EDGEFUSE, DATA, WORK = sys.argv[1:5]
ROBOT_SIM = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tools", "robot", "robot_sim.py")
BOARD = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "board", "host-sim", "edgefused.toml")
SPEED = 1.0  # sensors.replay_speed and robot_sim --speed
failures = []


def check(cond, what):
    print(("ok   " if cond else "FAIL ") + what, flush=True)
    if not cond:
        failures.append(what)


def cycle(mode, name=None):
    """One edgefused run driven by robot_sim; returns robot_sim's summary (None when it did not run)."""
    work = os.path.join(WORK, name or mode)
    os.makedirs(work, exist_ok=True)
    log_path = os.path.join(work, "edgefused.log")
    log = open(log_path, "w+")
    d = popen([*EMU, EDGEFUSED, "--board", "host-sim", "--config", BOARD, "--set", "sensors.replay=" + os.path.join(DATA, "bin_rig_a"),
               "--set", "link.tcp_port=0", "--set", "robot.text_port=0", "--set", "link.serial=", "--set", "console.echo=false",
               "--set", "tracking.poses=" + mode, "--set", "tracking.sim_truth=false", "--set", "robot.latency_us=10000",
               "--set", "sensors.replay_speed=%g" % SPEED, "--set", "calib.dir=" + os.path.join(work, "state")], stdout=log, stderr=subprocess.STDOUT)
    info = wait_started(d, log, 60)
    if "ready" not in info or "robot" not in info or "console" not in info:
        log.seek(0)
        print(log.read())
        check(False, "%s: edgefused started" % mode)
        d.kill()
        return None
    summary_path = os.path.join(work, "summary.json")
    r = subprocess.run(["/usr/bin/python3", ROBOT_SIM, "--port", info["robot"].rsplit(":", 1)[1], "--data", os.path.join(DATA, "bin_rig_a"),
                        "--console", info["console"], "--log", log_path, "--edgefuse", EDGEFUSE, "--out", work,
                        "--summary", summary_path, "--speed", "%g" % SPEED, "--max-median-mm", "100", "--max-median-deg", "100"],
                       capture_output=True, text=True, timeout=240 * SLOW)
    print(r.stdout + r.stderr, flush=True)
    d.send_signal(signal.SIGTERM)
    d.wait(timeout=20 * SLOW)
    check(d.returncode == 0, "%s: SIGTERM stops edgefused cleanly" % mode)
    log.seek(0)
    out = log.read()
    check("localize: 0 frames skipped without a robot pose" in out,
          "%s: every frame had the robot's pose at its stamp" % mode)
    if not os.path.exists(summary_path):
        check(False, "%s: robot_sim finished the cycle (exit %d)" % (mode, r.returncode))
        return None
    with open(summary_path) as f:
        return json.load(f)


os.makedirs(WORK, exist_ok=True)
runs = {mode: cycle(mode) for mode in ("robot", "robot+icp")}
# The localiser now and then takes a bin wall for a row of boxes and misses objects whatever the
# poses (measured: 1 robot+icp run in about 20, also with robot alone): robot+icp gets one more run then.
s = runs["robot+icp"]
if s is not None and s.get("found", 0) < s.get("truth", 6) - 1:
    print("robot+icp: %d of %d objects found, %d stray estimates: the localiser's miss; once more" %
          (s.get("found", 0), s.get("truth", 6), s.get("unmatched", 0)), flush=True)
    runs["robot+icp"] = cycle("robot+icp", "robot+icp-again")
for mode, s in runs.items():
    if s is None:
        continue
    check(s.get("pose_rate_hz", 0) >= 200, "%s: %d POSE updates at %.0f Hz" % (mode, s.get("pose_updates", 0), s.get("pose_rate_hz", 0)))
    off = s.get("timing_offset_ms")
    check(off is not None and abs(off) <= 50 * SLOW, "%s: the replay's time base starts %s ms from the CAPTURE reply (+: after)" %
          (mode, "%+.2f" % off if off is not None else "?"))
    print("%s: found %s/%s, median %.2f mm / %.3f deg" % (mode, s.get("found"), s.get("truth"), s.get("median_mm", -1), s.get("median_deg", -1)))
icp, rob = runs.get("robot+icp"), runs.get("robot")


def within(s, mm, deg):
    return sum(1 for p in s["per_object"] if p[1] <= mm and p[2] <= deg)


if icp is not None and "median_mm" in icp:
    # The localiser misses one object now and then whatever the poses (measured with the set's exact
    # poses too): 5 of 6 is the floor.
    check(icp["found"] >= icp["truth"] - 1, "robot+icp: objects delivered and matched %d/%d" % (icp["found"], icp["truth"]))
    worst = max(icp["per_object"], key=lambda p: p[1])
    check(all(p[1] <= 5.0 and p[2] <= 10.0 for p in icp["per_object"]),
          "robot+icp: each object within 5 mm / 10 deg (worst object %d: %.2f mm %.2f deg)" % tuple(worst))
    check(icp["median_mm"] <= 1.5 and icp["median_deg"] <= 1.5,
          "robot+icp: median %.2f mm / %.3f deg <= 1.5 mm / 1.5 deg" % (icp["median_mm"], icp["median_deg"]))
    if rob is not None and "median_mm" in rob:
        # No worse than robot alone: as many objects within 2 mm / 2 deg (one less allowed: the
        # localiser's spread between runs is larger than the modes' difference on this set), no more
        # stray estimates, the translation median at most 0.5 mm above.
        check(within(icp, 2, 2) >= within(rob, 2, 2) - 1 and icp["unmatched"] <= rob["unmatched"]
              and icp["median_mm"] <= rob["median_mm"] + 0.5,
              "robot+icp (%d within 2 mm / 2 deg, %d stray, median %.2f mm) no worse than robot (%d, %d stray, %.2f mm)" %
              (within(icp, 2, 2), icp["unmatched"], icp["median_mm"], within(rob, 2, 2), rob["unmatched"], rob["median_mm"]))
else:
    check(False, "robot+icp: objects checked against the truth")
print("FAILED: %d checks" % len(failures) if failures else "all checks passed")
sys.exit(1 if failures else 0)
