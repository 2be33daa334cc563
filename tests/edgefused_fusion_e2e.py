#!/usr/bin/python3
"""End to end with the real pipeline: edgefused on host-sim replays the bin_rig_a rig set
(--set sensors.replay=DIR: the xtion's frames through the HAL's replay backend, each once, at the
set's ground-truth poses with tracking.poses=known; the rig's object models from its rig.toml), is
driven over its console pseudo-terminal (scan start; the still-period trigger after the recording ends; localize), and
streams the poses over TCP to `edgefuse listen --csv`; `edgefuse eval poses` compares them with the
set's objects.txt (symmetry-aware).

Tolerance: 5 mm / 5 degrees per object (the localiser reaches ~0.7 mm median on this set; 5 mm is
2.5 voxels of 2 mm and the set's 5 mm/5 deg recall criterion). Required: objects 1 (can),
2 (bracket), 3 (box), 4 (cylinder) and 6 (box). Object 5, the upright bracket, is seen only as two
small fragments by the xtion and is not required (nor is box 3 in the fixed-point build, whose
`edgefuse localize` misses it too); no reported pose may be unmatched (a false
positive above localize.min_score).

usage: edgefused_fusion_e2e.py [--emulator CMD] [--time-factor F] [--no-sim-scene]
                               EDGEFUSED EDGEFUSE DATA_DIR WORKDIR [sanitized|plain] [fixed|float]
Skips (exit 0 with a message) when DATA_DIR/bin_rig_a is absent. A second run tracks the poses
(tracking.poses=tracked, starting at the recording's pose with tracking.sim_truth=true); a third
uses the sim backend's own scene at its known poses (no replay, no models): model-free segments
must lie at every object of objects.txt.
  --emulator, --time-factor  the ARM builds run the programs under qemu-user, slower
                             (edgefused_helpers.emulation): the recording plays slower there
                             (REPLAY_SPEED), the checks are the same
  --no-sim-scene             no third run: the build's board lists real cameras in its hal.toml (the
                             sim backend's scene is host-sim's)
"""
import os
import re
import shutil
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from edgefused_helpers import (check, collect, command, emulation, failures, open_raw, popen,  # noqa: E402
                               sigterm_and_wait, vm_data_kib, wait_recording_mapped, wait_started)

EMU, SLOW = emulation(sys.argv)
SIM_SCENE = "--no-sim-scene" not in sys.argv
if not SIM_SCENE:
    sys.argv.remove("--no-sim-scene")
EDGEFUSED, EDGEFUSE, DATA, WORK = (os.path.abspath(a) for a in sys.argv[1:5])
# Under AddressSanitizer its own bookkeeping maps memory: the flat-memory check is skipped there.
SANITIZED = len(sys.argv) > 5 and sys.argv[5] == "sanitized"
# The fixed-point build integrates in Q16.16: its map differs slightly, and there the localiser
# misses box 3 (so does that build's `edgefuse localize` on the same frames): not required there.
FIXED = len(sys.argv) > 6 and sys.argv[6] == "fixed"
RIG = os.path.join(DATA, "bin_rig_a")
REQUIRED = [1, 2, 4, 6] if FIXED else [1, 2, 3, 4, 6]
TOL_MM, TOL_DEG = 5.0, 5.0
# Playback speeds of the replayed runs (known poses, tracked): each camera streams on its own thread
# with the newest-frame policy, so a frame is dropped when processing falls behind the recording's
# rate, and the poses depend on every frame being in the map (the reasons at each run). Under
# qemu-user a 2 mm frame takes about 1 s at known poses and 2 s tracked (raycast and ICP too) on
# the 2-core VM with one other test running, and several times that when builds run beside it, so
# there the recording's 200 ms frames play at 4 s in both runs (on the host at 400 and 800 ms).
# Measured there at a load of 9-12: no frame dropped at 4 s; at 2 s the known-pose run dropped 4.
REPLAY_SPEED = (0.05, 0.05) if EMU else (0.5, 0.25)


def finish(text):
    """Ends the test: the failed checks and edgefused's last output, or that all passed."""
    if failures:
        print(text)
        print("%d check(s) failed" % len(failures))
        sys.exit(1)
    print("all checks passed")
    sys.exit(0)


def start(extra, logname):
    """Starts edgefused; returns (process, log file, startup info)."""
    log = open(os.path.join(WORK, logname), "w+")
    d = popen(EMU + [EDGEFUSED, "--set", "link.tcp_port=0", "--set", "robot.text_port=0", "--set", "link.serial=", "--set",
                     "console.echo=false", "--set", "calib.dir=" + os.path.join(WORK, "calib")] +
              extra, stdout=log, stderr=subprocess.STDOUT, cwd=WORK)
    info = wait_started(d, log, 120)  # start-up samples the models (a few seconds; more under sanitizers)
    return d, log, info


def stop(d, log, results):
    sigterm_and_wait(d, 30)
    log.seek(0)
    text = log.read()
    check(d.returncode == 0 and "stopped by SIGTERM after %d results" % results in text,
          "SIGTERM: clean stop (exit %s)" % d.returncode)
    return text


if not os.path.isfile(os.path.join(RIG, "objects.txt")):
    print("SKIP: no %s (the shared test data)" % RIG)
    sys.exit(0)
shutil.rmtree(WORK, ignore_errors=True)
os.makedirs(WORK)

# Half speed on the host (100 ms of recording per 200 ms; REPLAY_SPEED): each camera streams on its own thread with the
# newest-frame policy, so a frame is dropped when processing falls behind the camera, and five
# helpers compiling on a 2-core machine slow the integration several-fold (measured: 8 of 20 frames
# dropped at the recorded rate under a load of 9). The poses depend on every frame being in the map.
# The still period (after the recording ends) outlasts the calib fuse checks below, which run before
# the automatic localisation: 1 s, times the time factor under an emulator.
d, log, info = start(["--set", "sensors.replay=" + RIG, "--set", "tracking.poses=known", "--set",
                      "localize.still_period_s=%g" % (1 * SLOW), "--set",
                      "sensors.replay_speed=%g" % REPLAY_SPEED[0]], "edgefused.log")
check("ready" in info, "edgefused started with the real pipeline on the replay of bin_rig_a")
log.seek(0)
startup = log.read()
check("pipeline: camera xtion (replay of " in startup and "poses: known" in startup,
      "pipeline line: " + next((l for l in startup.splitlines() if l.startswith("pipeline:")), "(none)"))
if "ready" not in info:
    print(startup)
    d.kill()
    sys.exit(1)
# The board's cameras stream (its hal.toml's, each replaying the set's sensor of its name): host-sim
# and rpi4 have the xtion and the tof, am335x the xtion only, so there is no pair to calibrate.
m = re.search(r"^sensors: (.*) stream", startup, re.M)
HAS_TOF = m is not None and "tof" in [n.strip() for n in m.group(1).split(",")]
# The map's voxel edge (the board's [tsdf] default: 2 mm, am335x 4 mm).
m = re.search(r"volume \d+\^3 x (\S+) mm", startup)
VOXEL_MM = float(m.group(1)) if m else 0.0
port = int(info["tcp"].rsplit(":", 1)[1])
con = open_raw(info["console"])

r = command(con, "model list")
models = {}
for line in r.split("\r\n"):
    m = re.match(r"^(\d+) (\S+)$", line)
    if m:
        models[int(m.group(1))] = m.group(2)
check(sorted(models.values()) == ["box.ply", "bracket.ply", "can.ply", "cylinder.ply"],
      "model list: the rig's four models: %s" % models)

listen = popen(EMU + [EDGEFUSE, "listen", "--tcp", "127.0.0.1:%d" % port, "--csv", "--count", "2",
                      "--timeout-s", "%g" % (120 * SLOW)],
               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
time.sleep(0.5)  # the listener connects
check(command(con, "scan start").endswith("OK\r\n"), "console: scan start")
# The recording is one scan: its 20 frames are integrated once each, then the camera reports the
# end of the recording, the rig counts as still, and after localize.still_period_s (1 s) the
# runtime localises by itself (result 0). Then `localize` on the console gives result 1.
t0 = time.monotonic()
# Wait until every frame is accounted for, integrated or dropped (wait_recording_mapped). Newest-frame
# policy: a frame is lost only when the main loop stalls for a whole frame period (200 ms at the
# set's 5 fps); then it is counted as a drop.
frames, drops, status = wait_recording_mapped(con, 20, 120 * SLOW)
# Under an emulator a frame takes 1-2 s of the 4 s between frames, on two cores shared with other
# tests: a few more frames are dropped there (the map is still checked by the results below).
min_frames = 18 if not EMU else 14
check("end of recording" in status and frames + drops == 20 and frames >= min_frames,
      "mapping: %d frames integrated (%d dropped), then end of recording" % (frames, drops))
# Every camera streams on its own acquisition thread and shows its counters, the tof too.
check(re.search(r"device xtion ended \(end of recording\) \(map\) frames 20 published 20", status) is not None and
      (not HAS_TOF or
       re.search(r"device tof ended \(end of recording\) \(not in the map\) frames 20 published 20", status) is not None)
      and "rejects size 0 stamp 0 all_invalid 0 driver 0" in status and "faults timeouts" in status,
      "status: %s acquisition counters" % ("both cameras'" if HAS_TOF else "the camera's"))

# calib fuse on the live map: the tof's newest frame registered to the xtion's map, starting from
# the set's extrinsics; the result within 5 mm / 1 degree of extrinsics.txt (the calibration's
# 1-sigma is ~1 mm; measured 1.5 mm / 0.3 deg), stored and saved. Refusals are ERR 6 with the reason.
if HAS_TOF:
    r = command(con, "calib fuse xtion tof", timeout=60)
else:  # no pair to calibrate: refused, naming the camera
    r = command(con, "calib fuse xtion tof")
    check("ERR 6 no camera 'tof'" in r, "calib fuse xtion tof refused (no tof on this board): " + r.strip())
m = re.search(r"T_xtion_tof: t (\S+) (\S+) (\S+) q (\S+) (\S+) (\S+) (\S+)", r)
ok = m is not None and r.endswith("saved\r\nOK\r\n") and "uncertainty (1 sigma, tof frame)" in r
if ok:
    import math
    t = [float(m.group(i)) for i in (1, 2, 3)]
    q = [float(m.group(i)) for i in (4, 5, 6, 7)]
    ext = open(os.path.join(RIG, "extrinsics.txt")).read().split()
    te, qe = [float(x) for x in ext[2:5]], [float(x) for x in ext[5:9]]
    dt_mm = 1e3 * math.dist(t, te)
    dot = min(1.0, abs(sum(a * b for a, b in zip(q, qe))))
    dr_deg = math.degrees(2 * math.acos(dot))
    ok = dt_mm <= 5.0 and dr_deg <= 1.0
    print("calib fuse: %.2f mm / %.3f deg from extrinsics.txt" % (dt_mm, dr_deg))
if HAS_TOF:
    check(ok, "calib fuse xtion tof: T and uncertainty, saved: " + r.strip().replace("\r\n", " | "))
    calib_dir = os.path.join(WORK, "calib")
    check(os.path.isdir(calib_dir) and os.listdir(calib_dir) != [], "calib fuse: a calibration slot written")
    r = command(con, "calib show")
    check("T_xtion_tof:" in r, "calib show lists T_xtion_tof")
r = command(con, "calib fuse xtion laser")
check("ERR 6 'laser' is a line scanner" in r, "calib fuse xtion laser refused: " + r.strip())
if HAS_TOF:
    r = command(con, "calib fuse tof xtion")
    check("ERR 6 the map is built at xtion's poses" in r, "calib fuse tof xtion refused: " + r.strip())
r = command(con, "calib fuse xtion nosuch")
check("ERR 6 no camera 'nosuch'" in r, "calib fuse xtion nosuch refused: " + r.strip())
results = 0
while time.monotonic() < t0 + 180 * SLOW and results < 1:
    time.sleep(0.3)
    m = re.search(r"results (\d+)", command(con, "status"))
    results = int(m.group(1)) if m else 0
check(results == 1, "still-period trigger: a result without a command (%d)" % results)
vm_first = vm_data_kib(d.pid)
r = command(con, "localize")
check(r.endswith("OK\r\n"), "console: localize: " + r.strip())
t1 = time.monotonic()
out, err = collect(listen, 150)
print("second result arrived %.1f s after localize" % (time.monotonic() - t1))
vm_second = vm_data_kib(d.pid)
check(SANITIZED or (vm_first > 0 and vm_second == vm_first),
      "memory flat after start-up: VmData %d KiB after the first result, %d KiB after the second" % (vm_first, vm_second))
check(listen.returncode == 0, "edgefuse listen got two results (exit %s) %s" % (listen.returncode, err.strip()))
rows = [l.split(",") for l in out.strip().splitlines() if l and l[0].isdigit()]
print(out.strip())
check(all(int(r[1]) > 0 for r in rows), "capture stamps set")

for seq in (0, 1):
    # The poses in the pose-list format of `edgefuse localize --out`, evaluated against objects.txt.
    est = os.path.join(WORK, "poses_%d.txt" % seq)
    mine = [r for r in rows if int(r[0]) == seq]
    with open(est, "w") as f:
        for k, r in enumerate(mine):
            f.write("%d %s %s %s\n" % (k + 1, " ".join(r[3:10]), r[10], models.get(int(r[2]), "unknown")))
    ev = subprocess.run(EMU + [EDGEFUSE, "eval", "poses", est, os.path.join(RIG, "objects.txt")],
                        capture_output=True, text=True)
    print(ev.stdout.strip())
    check(ev.returncode == 0, "result %d: eval poses ran %s" % (seq, ev.stderr.strip()))
    for oid in REQUIRED:
        m = re.search(r"^object %d \((\S+)\): est #\d+ score \S+\s+t_err (\S+) mm\s+r_err (\S+) deg" % oid, ev.stdout,
                      re.M)
        ok = m is not None and float(m.group(2)) <= TOL_MM and float(m.group(3)) <= TOL_DEG
        check(ok, "result %d: object %d within %.0f mm / %.0f deg: %s" % (seq, oid, TOL_MM, TOL_DEG,
                                                                         m.group(0) if m else "not found"))
    m = re.search(r"unmatched_estimates=(\d+)", ev.stdout)
    check(m is not None and int(m.group(1)) == 0,
          "result %d: no false positives (unmatched estimates: %s)" % (seq, m.group(1) if m else "?"))
same = [r[2:] for r in rows if int(r[0]) == 0] == [r[2:] for r in rows if int(r[0]) == 1]
check(same, "the same map gives the same poses (deterministic)")

text = stop(d, log, 2)
if failures:
    print(text)

# --- tracked poses: the same replay, poses by ICP tracking against the raycast model (from the first
# frame's recorded pose standing in for the robot's, tracking.sim_truth), every frame pushed.
# Measured: tracking 0.4-0.5 mm from the truth at the last
# frame; all six objects within 5 mm / 5 deg. Required: no lost frame, all six, no false positive.
# (Box 3, in the bin's corner, is the knife edge of the tracked map: without the localiser's recheck
# round, LocalizeParams::recheck_score, it is missed, and a raycast rounding change of 1e-7 m lets a
# bracket claim its place; with it the box is found in the float and the Q16.16 build.)
# Played at quarter speed: tracking (raycast + ICP) takes a good part of the 200 ms frame period on a
# loaded 2-core machine, and with the newest-frame policy a late frame is dropped, which changes
# the map (measured: 2 of 20 frames dropped under load lost the can).
d, log, info = start(["--set", "sensors.replay=" + RIG, "--set", "localize.still_period_s=1", "--set",
                      "tracking.poses=tracked", "--set", "tracking.sim_truth=true",
                      "--set", "tracking.push_every_frame=true",
                      "--set", "sensors.replay_speed=%g" % REPLAY_SPEED[1]], "edgefused_tracked.log")
check("ready" in info, "edgefused started with tracking.poses=tracked")
if "ready" in info:
    port = int(info["tcp"].rsplit(":", 1)[1])
    con = open_raw(info["console"])
    listen = popen(EMU + [EDGEFUSE, "listen", "--tcp", "127.0.0.1:%d" % port, "--csv", "--count", "1",
                          "--timeout-s", "%g" % (150 * SLOW)],
                   stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(0.5)
    check(command(con, "scan start").endswith("OK\r\n"), "tracked: scan start")
    out, err = collect(listen, 200)
    rows = [l.split(",") for l in out.strip().splitlines() if l[:1].isdigit()]
    check(listen.returncode == 0 and len(rows) > 0,
          "tracked: a result by the still-period trigger (%d rows; listen: %s)" % (len(rows), err.strip()))
    print(command(con, "status").strip())
    est = os.path.join(WORK, "poses_tracked.txt")
    with open(est, "w") as f:
        for k, r in enumerate(rows):
            f.write("%d %s %s %s\n" % (k + 1, " ".join(r[3:10]), r[10], models.get(int(r[2]), "unknown")))
    ev = subprocess.run(EMU + [EDGEFUSE, "eval", "poses", est, os.path.join(RIG, "objects.txt")],
                        capture_output=True, text=True)
    print(ev.stdout.strip())
    # All six on a 2 mm map; on a 4 mm map (board am335x) not object 5, the upright bracket: the two
    # small fragments of it the xtion sees (above) hold a quarter of the points there (measured: not
    # found in the Q16.16 am335x build under qemu; the known-pose run never requires it).
    for oid in [1, 2, 3, 4, 5, 6] if VOXEL_MM <= 2.0 else [1, 2, 3, 4, 6]:
        m = re.search(r"^object %d \((\S+)\): est #\d+ score \S+\s+t_err (\S+) mm\s+r_err (\S+) deg" % oid, ev.stdout,
                      re.M)
        ok = m is not None and float(m.group(2)) <= TOL_MM and float(m.group(3)) <= TOL_DEG
        check(ok, "tracked: object %d within %.0f mm / %.0f deg: %s" % (oid, TOL_MM, TOL_DEG,
                                                                        m.group(0) if m else "not found"))
    m = re.search(r"unmatched_estimates=(\d+)", ev.stdout)
    check(m is not None and int(m.group(1)) == 0, "tracked: no false positives")
    text = stop(d, log, 1)
    m = re.search(r"tracking: (\d+) lost frames, last pose (\S+) mm from", text)
    check(m is not None and int(m.group(1)) == 0 and float(m.group(2)) < 2.0,
          "tracked: %s" % (m.group(0) if m else "no tracking line"))
else:
    d.kill()

if not SIM_SCENE:
    print("skip the sim backend's scene: this board's hal.toml lists real cameras (host-sim's has the sim rig)")
    finish(text)

# --- the sim backend's own scene (no replay): bin_rig_a's objects as analytic solids, no models
# configured, so localize reports model-free segments (id 0) at box centres of the visible parts.
# Each object's position must have a segment within 30 mm horizontally (a segment's centre is that
# of the part the xtion sees, not the model's origin: up to half an object's size off; measured up
# to 6 mm, for the upright bracket 5).
# Well-posed by construction: the sim's solids keep at least 9.7 mm apart (can 1 and cylinder 4
# are the closest pair, as in the real meshes: 11.3 mm), about twice the segmentation's 5 mm
# neighbour radius. Solids that touch (a can stand-in touching the cylinder, dug 16 mm into the
# floor) would make the check flaky: which frames enter the map (each camera renders on its own
# thread; frames are dropped under load) would decide whether the two come out as one segment.
# Object 5, the upright bracket, is not required here either (as in the replay checks): from 0.7 m
# above, the xtion sees of it the 5 x 30 mm top edge of its vertical 80 mm plate, the plate's faces
# almost edge-on, and its flange lying 5 mm high, 1 mm above the bin removal's 4 mm floor band.
# Its segment hovers around the 150-point minimum, so whether it is reported depends on which
# frames the map holds (measured: found 4-6 mm off in 19 of 20 runs, most of them loaded; dropped in one).
SIM_UPRIGHT_BRACKET = 5
truth = {}
for line in open(os.path.join(RIG, "objects.txt")):
    f = line.split()
    if len(f) >= 8 and not line.startswith("#"):
        truth[int(f[0])] = (float(f[1]), float(f[2]))
d, log, info = start(["--set", "tracking.poses=known"], "edgefused_sim.log")
check("ready" in info, "edgefused started on the sim backend (no replay)")
if "ready" in info:
    port = int(info["tcp"].rsplit(":", 1)[1])
    con = open_raw(info["console"])
    listen = popen(EMU + [EDGEFUSE, "listen", "--tcp", "127.0.0.1:%d" % port, "--csv", "--count", "1",
                          "--timeout-s", "%g" % (120 * SLOW)],
                   stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(0.5)
    r = command(con, "calib fuse xtion tof")
    check("ERR 6 the map is empty" in r, "sim: calib fuse before a scan refused: " + r.strip())
    check(command(con, "scan start").endswith("OK\r\n"), "sim: scan start")
    frames = 0
    end = time.monotonic() + 120 * SLOW
    while time.monotonic() < end and frames < 30:
        time.sleep(0.5)
        m = re.search(r"frames (\d+)", command(con, "status"))
        frames = int(m.group(1)) if m else frames
    check(frames >= 30, "sim: %d frames integrated at the simulated rig's poses" % frames)
    check(command(con, "localize").endswith("OK\r\n"), "sim: localize")
    out, err = collect(listen, 150)
    segs = [(float(r[3]), float(r[4])) for r in (l.split(",") for l in out.strip().splitlines() if l[:1].isdigit())
            if r[2] == "0"]
    print(out.strip())
    check(listen.returncode == 0 and len(segs) > 0, "sim: %d segments received" % len(segs))
    for oid, (x, y) in sorted(truth.items()):
        dist = min((((sx - x) ** 2 + (sy - y) ** 2) ** 0.5 for sx, sy in segs), default=1.0)
        if oid == SIM_UPRIGHT_BRACKET:
            print("info sim: object %d (upright bracket, not required) nearest segment %.1f mm" % (oid, dist * 1e3))
            continue
        check(dist <= 0.030, "sim: object %d has a segment %.1f mm away horizontally" % (oid, dist * 1e3))
    # scan stop / start joins and restarts every acquisition thread: memory stays flat.
    vm = []
    for _ in range(6):
        command(con, "scan stop")
        command(con, "scan start")
        time.sleep(0.3)
        vm.append(vm_data_kib(d.pid))
    check(SANITIZED or len(set(vm[1:])) == 1, "sim: VmData flat over scan stop/start cycles: %s KiB" % vm)
    text = stop(d, log, 1)
else:
    d.kill()
    log.seek(0)
    text = log.read()
finish(text)
