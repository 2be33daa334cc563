"""robot_sim.py --handeye: the simulated robot calibrates its camera's mounting online, without a
target, against edgefused on the host-sim rig (sim backend, sensors.sim_path = the same file).

The rig follows a station path (a TUM-format file of rig poses in the sim world, two keys per
station; edgefused eases the moves between keys with smoothstep, as StationPath.at does here). The
robot carries the rig on its flange with its mounting T_flange_camera (--mount), so its flange path
is T_base_flange = T_world_rig * inv(T_flange_camera), the base frame being the sim world:
  1. the path's time base from edgefused's output (--log): `sim: rig path ... from clock T us`;
  2. CAPTURE (edgefused starts mapping and tracking by ICP; tracking.poses = icp, sim_truth = false:
     nothing from the simulator's truth);
  3. POSE at --rate Hz with the --error-mm / --error-deg error per update, as a controller streams;
  4. at every station still ahead, --settle-s after the rig arrived (and --warmup-s after CAPTURE):
     HANDEYE ADD with the flange pose (with the same error: the pose the robot reports);
  5. HANDEYE SOLVE (with --save: HANDEYE SAVE and CALIBRATION, which must return it); the solved T_flange_camera against --mount: translation error (mm), rotation
     error (deg), PASS / FAIL against the hand-eye targets (exact poses: 0.5 mm / 0.05 deg; 0.2 mm /
     0.02 deg of robot error: 1 mm / 0.1 deg). Exit 1 on FAIL or when a request failed.
"""
import json
import math
import re
import sys
import time

from edgefuse_robot import RobotClient, RobotError
from pose_math import angle_deg, compose, interpolate, inverse

TARGETS = ((0.0, 0.0, 0.5, 0.05), (0.2, 0.02, 1.0, 0.1))  # robot error mm, deg -> target mm, deg


def smoothstep(s):
    return s * s * (3 - 2 * s)


class StationPath:
    """The rig's key poses, interpolated as edgefused's SimRigPath (eased lerp + slerp)."""

    def __init__(self, keys):
        t0 = keys[0][0]
        self.keys = [(t - t0, pose) for t, pose in keys]
        self.stations = [(a[0], b[0], a[1]) for a, b in zip(self.keys, self.keys[1:]) if same(a[1], b[1])]

    def at(self, t):
        k = self.keys
        if t <= k[0][0]:
            return k[0][1]
        if t >= k[-1][0]:
            return k[-1][1]
        i = next(i for i in range(1, len(k)) if k[i][0] >= t)
        (ta, a), (tb, b) = k[i - 1], k[i]
        return interpolate(a, b, smoothstep((t - ta) / (tb - ta)))


def same(a, b):
    return math.dist(a[0], b[0]) < 1e-6 and angle_deg(a[1], b[1]) < 1e-4


def path_epoch_s(log_path, timeout_s=10.0):
    """The HAL clock time (s) the sim rig's path started at, from edgefused's start-up line."""
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        with open(log_path, errors="replace") as f:
            m = re.search(r"^sim: rig path .* from clock (\d+) us", f.read(), re.M)
        if m:
            return int(m.group(1)) * 1e-6
        time.sleep(0.1)
    raise SystemExit("robot_sim: no 'sim: rig path ... from clock T us' line in %s: is sensors.sim_path set?" % log_path)


def target_for(mm, deg):
    """The issue's target for this robot error, or None when the error is larger than both."""
    for e_mm, e_deg, t_mm, t_deg in TARGETS:
        if mm[1] <= e_mm + 1e-12 and deg[1] <= e_deg + 1e-12:
            return t_mm, t_deg
    return None


def run(args, T_fc, errors, read_poses, words):
    """Hand-eye mode of robot_sim.py (see the module comment); returns the exit status."""
    if not args.log:
        raise SystemExit("robot_sim: --handeye needs --log (edgefused's output: the path's time base)")
    path = StationPath(read_poses(args.handeye))
    T_cf = inverse(T_fc)
    epoch = path_epoch_s(args.log)
    print("robot_sim: hand-eye on %s: %d stations over %.1f s, T_flange_camera = %s" %
          (args.handeye, len(path.stations), path.keys[-1][0], " ".join("%g" % v for v in words(T_fc))), flush=True)

    def flange(t):
        return compose(path.at(t), T_cf)

    summary = {"error_mm": errors.mm, "error_deg": errors.deg, "stations_path": len(path.stations)}
    robot = RobotClient().connect(args.host, args.port, timeout_s=10)
    try:
        robot.capture(words(errors.apply(flange(time.monotonic() - epoch))))
        t_capture = time.monotonic() - epoch
        # Tracking needs a few frames of the map before its pose counts.
        ahead = [(max(a + args.settle_s, t_capture + args.warmup_s), a, b) for a, b, _ in path.stations]
        ahead = [s for s in ahead if s[0] <= s[2] - 0.1]
        print("robot_sim: CAPTURE at path time %.2f s; %d of %d stations ahead" %
              (t_capture, len(ahead), len(path.stations)), flush=True)
        added = stream_and_add(robot, ahead, flange, errors, epoch, args, words)
        summary["stations"] = added
        he = robot.handeye_solve()
        if args.save:
            summary["saved"] = save(robot, he)
        st = robot.status()
        print("robot_sim: STATUS -> %s %s" % (st.state, st.tracking))
    except RobotError as e:
        print("robot_sim: %s" % e, file=sys.stderr)
        return 1
    finally:
        robot.close()
    return judge(he, T_fc, errors, summary, args)


def stream_and_add(robot, stations, flange, errors, epoch, args, words):
    """POSE at args.rate until the last station's HANDEYE ADD; stations are (add time, arrival, departure)
    on the path's clock. Returns the stations added."""
    period = 1.0 / args.rate
    added, n = 0, 0
    t_next = time.monotonic()
    for t_add, t_arrive, t_leave in stations:
        while time.monotonic() - epoch < t_add:
            robot.pose(words(errors.apply(flange(time.monotonic() - epoch))))
            n += 1
            t_next += period
            time.sleep(max(0.0, t_next - time.monotonic()))
        t = time.monotonic() - epoch
        added = robot.handeye_add(words(errors.apply(flange(t))))
        print("robot_sim: HANDEYE ADD at path time %.2f s (station %.1f-%.1f s) -> OK %d" %
              (t, t_arrive, t_leave, added), flush=True)
    print("robot_sim: %d POSE updates" % n)
    return added


def save(robot, he):
    """HANDEYE SAVE, then CALIBRATION: True when the store returns the solved mounting."""
    robot.handeye_save()
    stored = robot.calibration()
    same_pose = math.dist(stored[:3], he.pose[:3]) < 1e-5 and angle_deg(stored[3:7], he.pose[3:7]) < 1e-3
    print("robot_sim: HANDEYE SAVE -> OK; CALIBRATION -> %s (%s)" %
          (" ".join("%.6f" % v for v in stored), "the solved mounting" if same_pose else "NOT the solved mounting"))
    return same_pose


def judge(he, T_fc, errors, summary, args):
    t, q = tuple(he.pose[:3]), tuple(he.pose[3:7])
    err_mm = 1e3 * math.dist(t, T_fc[0])
    err_deg = angle_deg(q, T_fc[1])
    summary.update(solved=list(he.pose), residual_mm=he.residual_mm, residual_deg=he.residual_deg,
                   error_mm_result=err_mm, error_deg_result=err_deg)
    print("robot_sim: HANDEYE SOLVE -> %s, residual %.3f mm / %.4f deg RMS over the stations" %
          (" ".join("%.6f" % v for v in he.pose), he.residual_mm, he.residual_deg))
    target = target_for(errors.mm, errors.deg)
    status = 0
    if target is None:
        verdict = "no target for %g mm / %g deg of robot error" % (errors.mm[1], errors.deg[1])
    else:
        ok = err_mm <= target[0] and err_deg <= target[1]
        verdict = "%s (target %g mm / %g deg)" % ("PASS" if ok else "FAIL", target[0], target[1])
        summary["target_met"] = ok
        status = 0 if ok else 1
    print("robot_sim: hand-eye error against the mounting: %.3f mm / %.4f deg: %s" % (err_mm, err_deg, verdict))
    if args.summary:
        with open(args.summary, "w") as f:
            json.dump(summary, f, indent=1)
    return status
