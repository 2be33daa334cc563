#!/usr/bin/python3
"""`edgefuse localize --robot FILE --hand-eye FILE|calibrated` on handeye_rig_a (robot flange poses
and objects in one set): the frames fused at T_base_flange(stamp) * T_flange_xtion give the objects
in the robot's base frame. Checked against
  - the plain localisation (the set's ground-truth camera poses, world frame) moved by
    robot/truth.txt's T_base_world: at least 5 of the 6 objects in each, those found by both within
    2 mm / 2 degrees (the two maps sample the scene on different voxel grids, so a localiser miss
    may differ; measured 0.75 mm / 1.0 degree, a bracket);
  - objects.txt moved by T_base_world: every reported pose within 5 mm / 5 degrees of a true
    object of its model (symmetric models: the position only);
  - the mounting taken from a calibration store written by edgefused itself (`calib set flange`,
    `calib save` on its console; --hand-eye calibrated --store DIR): the same pose list as from the
    pose file.
And the refusals: --robot without --hand-eye, a store without a hand-eye, a mounting named for
another sensor.

usage: localize_robot_cli.py EDGEFUSE EDGEFUSED DATA_DIR WORKDIR
Skips (exit 0) when DATA_DIR/handeye_rig_a is absent.
"""
import math
import os
import shutil
import signal
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from edgefused_helpers import check, command, failures, open_raw, popen, wait_started  # noqa: E402
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tools", "robot"))
from pose_math import angle_deg as qangle, compose  # noqa: E402

EDGEFUSE, EDGEFUSED, DATA, WORK = (os.path.abspath(a) for a in sys.argv[1:5])
SET = os.path.join(DATA, "handeye_rig_a")
MODELS = ["box", "bracket", "can", "cylinder"]
SYMMETRIC = {"box", "cylinder"}  # discrete / continuous symmetries: rotation not compared to the truth
def run(args, want_exit=0):
    r = subprocess.run([EDGEFUSE, "localize", SET] + args, capture_output=True, text=True, cwd=WORK, timeout=600)
    if r.returncode != want_exit:
        print(r.stdout[-3000:], r.stderr[-3000:])
    return r


def poses(path):
    """[(model, (t, q), score)] from `--out`: id tx ty tz qx qy qz qw score model."""
    out = []
    for line in open(path):
        w = line.split()
        if len(w) == 10 and not line.startswith("#"):
            v = [float(x) for x in w[1:9]]
            out.append((w[9].replace(".ply", ""), (tuple(v[0:3]), tuple(v[3:7])), v[7]))
    return out


if not os.path.isfile(os.path.join(SET, "objects.txt")):
    print("SKIP: no %s (the shared test data)" % SET)
    sys.exit(0)
shutil.rmtree(WORK, ignore_errors=True)
os.makedirs(WORK)
truth = {}
for line in open(os.path.join(SET, "robot", "truth.txt")):
    w = line.split()
    if len(w) == 8:
        v = [float(x) for x in w[1:]]
        truth[w[0]] = (tuple(v[0:3]), tuple(v[3:7]))
T_flange_xtion, T_base_world = truth["T_flange_xtion"], truth["T_base_world"]
mount = os.path.join(WORK, "mount.txt")
with open(mount, "w") as f:  # as `edgefuse handeye --out` appends it
    f.write("T_flange_xtion %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n" % (T_flange_xtion[0] + T_flange_xtion[1]))
model_args = []
for m in MODELS:
    model_args += ["--model", os.path.join(SET, "models", m + ".ply")]
robot = os.path.join(SET, "robot", "flange.txt")

# --- refusals ------------------------------------------------------------------------------------
r = run(model_args + ["--robot", robot], 2)
check(r.returncode == 2 and "--robot FILE and --hand-eye" in r.stderr, "--robot without --hand-eye refused (exit 2)")
wrong = os.path.join(WORK, "wrong.txt")
with open(wrong, "w") as f:
    f.write("T_flange_tof 0 0 0 0 0 0 1\n")
r = run(model_args + ["--robot", robot, "--hand-eye", wrong], 1)
check(r.returncode == 1 and "the mounting is T_flange_tof" in r.stderr, "a mounting for another sensor refused")
r = run(model_args + ["--robot", robot, "--hand-eye", "calibrated", "--store", os.path.join(WORK, "nostore")], 1)
check(r.returncode == 1 and "no valid slot" in r.stderr, "--hand-eye calibrated without a store refused")

# --- the plain localisation (ground-truth poses, world frame) and the robot's (base frame) ------
plain_out, robot_out = os.path.join(WORK, "plain.txt"), os.path.join(WORK, "robot.txt")
r = run(model_args + ["--out", plain_out])
check(r.returncode == 0, "plain localize (truth poses): exit %d" % r.returncode)
r = run(model_args + ["--robot", robot, "--hand-eye", mount, "--out", robot_out])
check(r.returncode == 0 and "poses in the robot's base frame" in r.stdout and "14 frames, 0 without" in r.stdout,
      "localize --robot --hand-eye FILE: exit %d, %s" % (r.returncode,
                                                       next((l for l in r.stdout.splitlines() if l.startswith("poses:")), "")))
plain = [(m, compose(T_base_world, p), s) for m, p, s in poses(plain_out)] if os.path.isfile(plain_out) else []
based = poses(robot_out) if os.path.isfile(robot_out) else []
# The two maps are fused on different grids (axis-aligned in the world and in the base frame), so
# the localiser may miss a different part in each (measured in the Q16.16 build: 6 and 5 of 6).
check(len(plain) >= 5 and len(based) >= 5, "objects: %d with robot poses, %d plain (of 6)" % (len(based), len(plain)))
worst_t = worst_r = 0.0
matched = 0
for m, p, _ in based:
    cand = [q for mm, q, _ in plain if mm == m]
    if not cand:
        continue
    q = min(cand, key=lambda c: math.dist(c[0], p[0]))
    dt, dr = math.dist(q[0], p[0]), qangle(q[1], p[1])
    if dt < 0.01:
        matched += 1
        worst_t, worst_r = max(worst_t, dt), max(worst_r, dr if m not in SYMMETRIC else 0.0)
check(matched >= min(len(based), len(plain)) and len(based) > 0 and worst_t <= 0.002 and worst_r <= 2.0,
      "robot-frame poses = plain poses x T_base_world: %d of %d matched, worst %.2f mm %.2f deg" %
      (matched, len(based), 1e3 * worst_t, worst_r))

objects = []
rig_models = {}
cur = None
for line in open(os.path.join(SET, "rig.toml")):
    line = line.strip()
    if line.startswith("id ="):
        cur = int(line.split("=")[1])
    elif line.startswith("model =") and cur is not None:
        rig_models[cur] = line.split("=")[1].strip().strip('"').split("/")[-1].replace(".ply", "")
for line in open(os.path.join(SET, "objects.txt")):
    w = line.split()
    if len(w) == 8 and not line.startswith("#"):
        v = [float(x) for x in w[1:]]
        objects.append((rig_models.get(int(w[0]), "?"), compose(T_base_world, (tuple(v[0:3]), tuple(v[3:7])))))
errs = []
for m, p, _ in based:
    cand = [q for mm, q in objects if mm == m]
    q = min(cand, key=lambda c: math.dist(c[0], p[0])) if cand else None
    errs.append((m, 1e3 * math.dist(q[0], p[0]) if q else float("inf"),
                 (qangle(q[1], p[1]) if m not in SYMMETRIC else 0.0) if q else float("inf")))
check(len(errs) > 0 and all(e[1] <= 5.0 and e[2] <= 5.0 for e in errs),
      "base-frame poses at objects.txt x T_base_world: %s" % ", ".join("%s %.1f mm %.1f deg" % e for e in errs))

# --- the mounting from a calibration store edgefused wrote -----------------------------------------
store = os.path.join(WORK, "store")
log = open(os.path.join(WORK, "edgefused.log"), "w+")
d = popen([EDGEFUSED, "--set", "link.tcp_port=0", "--set", "robot.text_port=0", "--set", "link.serial=", "--set",
           "console.echo=false", "--set", "calib.dir=" + store], stdout=log, stderr=subprocess.STDOUT, cwd=WORK)
info = wait_started(d, log, 60)
if check("ready" in info, "edgefused started (to write a calibration store)"):
    con = open_raw(info["console"])
    r1 = command(con, "calib set flange %.9f %.9f %.9f %.9f %.9f %.9f %.9f" % (T_flange_xtion[0] + T_flange_xtion[1]))
    r2 = command(con, "calib save")
    check(r1.endswith("OK\r\n") and r2.endswith("OK\r\n"), "edgefused: calib set flange, calib save")
d.send_signal(signal.SIGTERM)
d.wait(timeout=30)
store_out = os.path.join(WORK, "store.txt")
r = run(model_args + ["--robot", robot, "--hand-eye", "calibrated", "--store", store, "--out", store_out])
check(r.returncode == 0 and "calibration store" in r.stdout, "localize --hand-eye calibrated --store DIR: exit %d" % r.returncode)
from_store = poses(store_out) if os.path.isfile(store_out) else []
same = len(from_store) == len(based) and all(
    a[0] == b[0] and math.dist(a[1][0], b[1][0]) < 2e-5 and qangle(a[1][1], b[1][1]) < 0.01
    for a, b in zip(from_store, based))
check(same, "the store's mounting gives the pose file's poses (%d objects)" % len(from_store))

if failures:
    print("%d check(s) failed" % len(failures))
    sys.exit(1)
print("all checks passed")
