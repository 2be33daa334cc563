#!/usr/bin/python3
"""The robot example programs' exchanges (tools/robot/examples/*.exchange) replayed against a live
edgefused: host-sim replaying the bin_rig_a rig set at its true poses (tracking.poses=known). Each
exchange runs on its own edgefused: the lines the program sends (its flange pose filled in, in the
connection's units and rotation convention), the scan (the test waits on the console until every
frame of the recording was integrated or dropped), then DETECT and NEXT until NO_OBJECTS with
PICKED (every third pick FAILED). Every reply must match one of the forms the program parses, word
for word (field counts, integers where it reads integers). Before CAPTURE (no map yet) its DETECT
must come back in its ERR form and its NEXT as NO_OBJECTS. Then a second connection in the default convention (m, xyzw)
detects again on the same map: every object the program was offered must come back in that
convention at the same pose (the localiser is deterministic on one map), which checks units and
rotation convention; and at least three of them must lie within 10 mm of objects.txt's, which
checks the frame and the scale.

usage: robot_examples_e2e.py [--emulator CMD] [--time-factor F] EDGEFUSED DATA_DIR EXAMPLES_DIR WORKDIR
Skips (exit 0 with a message) when DATA_DIR/bin_rig_a is absent.
"""
import glob
import math
import os
import re
import shutil
import socket
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from edgefused_helpers import (TextClient, check, emulation, failures, open_raw, popen, sigterm_and_wait,  # noqa: E402
                               wait_recording_mapped, wait_started)
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tools", "robot"))
from pose_math import angle_deg as quat_angle_deg, axis_angle, qmul as quat_mul  # noqa: E402

EMU, SLOW = emulation(sys.argv)
EDGEFUSED, DATA, EXAMPLES, WORK = (os.path.abspath(a) for a in sys.argv[1:5])
RIG = os.path.join(DATA, "bin_rig_a")
# The flange pose the programs report at CAPTURE and DETECT (T_base_flange: 0.4 m in front of the
# base, 0.6 m up, the tool pointing down, turned 30 degrees about the base's z). With
# tracking.poses=known the map does not depend on it; it must only be well-formed.
FLANGE_T = (0.4, -0.05, 0.6)
INT_FIELDS = {"id", "n", "left", "code"}
# Half speed on the host (as edgefused_fusion_e2e.py): a frame is dropped when the integration falls
# behind the recording, and builds beside the test slow it several-fold; frames missing from the
# map can add false poses (the last check needs only three objects at their true place).
REPLAY_SPEED = 0.05 if EMU else 0.5
# --- rotations ------------------------------------------------------------------------------------
def quat_axis(axis, deg):
    return axis_angle(axis, math.radians(deg))


def quat_from_rotvec(r):
    a = math.sqrt(sum(c * c for c in r))
    if a < 1e-12:
        return (0.0, 0.0, 0.0, 1.0)
    return quat_axis(tuple(c / a for c in r), math.degrees(a))


def rotvec_from_quat(q):
    x, y, z, w = q
    if w < 0:
        x, y, z, w = -x, -y, -z, -w
    s = math.sqrt(x * x + y * y + z * z)
    if s < 1e-12:
        return (0.0, 0.0, 0.0)
    a = 2 * math.atan2(s, w)
    return (x / s * a, y / s * a, z / s * a)


def quat_from_abc(a, b, c):  # KUKA: R = Rz(A) Ry(B) Rx(C), degrees
    return quat_mul(quat_mul(quat_axis((0, 0, 1), a), quat_axis((0, 1, 0), b)), quat_axis((1, 0, 0), c))


def abc_from_quat(q):
    x, y, z, w = q
    r00 = 1 - 2 * (y * y + z * z)
    r10 = 2 * (x * y + z * w)
    r20 = 2 * (x * z - y * w)
    r21 = 2 * (y * z + x * w)
    r22 = 1 - 2 * (x * x + y * y)
    return (math.degrees(math.atan2(r10, r00)), math.degrees(math.asin(max(-1.0, min(1.0, -r20)))),
            math.degrees(math.atan2(r21, r22)))


FLANGE_Q = quat_mul(quat_axis((0, 0, 1), 30), quat_axis((0, 1, 0), 180))


# --- the exchange files ---------------------------------------------------------------------------
def read_exchange(path):
    """Steps: ("send", template), ("reply", [forms]), ("scan",), ("loop", until_form, [steps])."""
    top, stack = [], []
    cur = top
    for raw in open(path):
        line = raw.rstrip("\n")
        if not line.strip() or line.startswith("#"):
            continue
        if line.startswith("> "):
            cur.append(("send", line[2:]))
        elif line.startswith("< "):
            cur.append(("reply", [f.strip().split() for f in line[2:].split(" | ")]))
        elif line == "= scan":
            cur.append(("scan",))
        elif line.startswith("= loop "):
            block = []
            cur.append(("loop", line[7:].split(), block))
            stack.append(cur)
            cur = block
        elif line == "= end":
            cur = stack.pop()
        else:
            raise ValueError("%s: unreadable line %r" % (path, line))
    return top


def matches(words, form):
    """{field: value} when the reply's words have the form (same count, literals equal, numbers
    where the form has names), else None."""
    rest = form and form[-1].endswith("...")
    if (len(words) < len(form) - 1) if rest else (len(words) != len(form)):
        return None
    got = {}
    for k, f in enumerate(form):
        if f.endswith("..."):
            got[f[:-3]] = " ".join(words[k:])
            break
        w = words[k]
        if f.isupper() or not f[0].isalpha():
            if w != f:
                return None
            continue
        try:
            got[f] = int(w) if f in INT_FIELDS else float(w)
        except ValueError:
            return None
        if f not in INT_FIELDS and not math.isfinite(got[f]):
            return None
    return got


class Conn(TextClient):
    """A text-port connection that remembers the conventions the exchange set (UNITS, ROTATION)."""

    def __init__(self, port):
        super().__init__(port, 120)
        self.units, self.rotation = "m", "xyzw"


def flange_values(units, rotation, template):
    """The flange pose's numbers by the names the template uses, formatted as the program does."""
    s = 1000.0 if units == "mm" else 1.0
    v = {"x": FLANGE_T[0] * s, "y": FLANGE_T[1] * s, "z": FLANGE_T[2] * s}
    if rotation == "axisangle":
        v.update(zip(("rx", "ry", "rz"), rotvec_from_quat(FLANGE_Q)))
    elif rotation == "kuka_abc":
        v.update(zip(("a", "b", "c"), abc_from_quat(FLANGE_Q)))
    elif rotation == "wxyz":
        v.update(zip(("qw", "qx", "qy", "qz"), (FLANGE_Q[3],) + FLANGE_Q[:3]))
    else:
        v.update(zip(("qx", "qy", "qz", "qw"), FLANGE_Q))
    # URScript's to_str(pose) prints "p[x, y, z, rx, ry, rz]" (the template keeps its commas);
    # KRL's SWRITE %f prints 6 decimals.
    fmt = "%.6f" if "," not in template else "%.5g"
    return {k: fmt % x for k, x in v.items()}


def fill(template, units, rotation):
    values = flange_values(units, rotation, template)

    head, _, rest = template.partition(" ")
    if head == "PICKED":  # the program sends OK or FAILED: every third pick fails here
        fill.picks = getattr(fill, "picks", 0) + 1
        return "PICKED FAILED" if fill.picks % 3 == 0 else "PICKED OK"
    if head not in ("CAPTURE", "POSE", "DETECT", "HANDEYE"):
        return template  # UNITS m, ROTATION axisangle, NEXT, ...: as written
    return head + (" " + re.sub(r"\b[a-z][a-z0-9]*\b", lambda m: values[m.group(0)], rest) if rest else "")


def object_pose(got, prefix, units, rotation):
    """(translation in m, quaternion xyzw) of an OBJECT reply's pose (prefix "" or "g" for the grasp)."""
    s = 0.001 if units == "mm" else 1.0
    t = tuple(got[prefix + k] * s for k in ("x", "y", "z"))
    if rotation == "axisangle":
        q = quat_from_rotvec(tuple(got[prefix + k] for k in ("rx", "ry", "rz")))
    elif rotation == "kuka_abc":
        q = quat_from_abc(*(got[prefix + k] for k in ("a", "b", "c")))
    elif rotation == "wxyz":
        w, x, y, z = (got[prefix + k] for k in ("qw", "qx", "qy", "qz"))
        q = (x, y, z, w)
    else:
        q = tuple(got[prefix + k] for k in ("qx", "qy", "qz", "qw"))
    return t, q


def grasp_names(form):
    return {f[1:] if f.startswith("g") and len(f) > 1 else f for f in form}


def wait_scan(con):
    """Until the recording ended and every frame was integrated or dropped (console status)."""
    frames, drops, status = wait_recording_mapped(con, 20, 60 * SLOW)
    check("end of recording" in status and frames + drops == 20 and frames > 0,
          "scan: %d frames integrated, %d dropped, end of recording" % (frames, drops))


class Run:
    def __init__(self, conn, con):
        self.c, self.con = conn, con
        self.objects = []  # (id, score, t, q, grasp t, grasp q) as offered
        self.detected = None
        self.detect_ms = 0.0

    def reply(self, text, forms, sent):
        words = text.split()
        for form in forms:
            got = matches(words, form)
            if got is not None:
                return form, got
        check(False, "%r -> %r matches none of the forms %s" % (sent, text, [" ".join(f) for f in forms]))
        return None, None

    def steps(self, steps):
        """Runs the steps; returns the last reply's form (for loops)."""
        last_form, sent, pending = None, None, None
        for st in steps:
            if st[0] == "send":
                sent = fill(st[1], self.c.units, self.c.rotation)
                t0 = time.monotonic()
                pending = self.c.ask(sent)
                ms = 1000 * (time.monotonic() - t0)
                words = sent.split()
                if words[0] == "UNITS":
                    self.c.units = words[1]
                elif words[0] == "ROTATION":
                    self.c.rotation = words[1]
                elif words[0] == "DETECT":
                    self.detect_ms = ms
            elif st[0] == "reply":
                form, got = self.reply(pending, st[1], sent)
                last_form = form
                if form is None:
                    raise RuntimeError("stopping this exchange at the unparsed reply")
                self.judge(sent, pending, form, got)
            elif st[0] == "scan":
                wait_scan(self.con)
            elif st[0] == "loop":
                for _ in range(64):
                    form = self.steps_until(st[2], st[1])
                    if form == st[1]:
                        break
        return last_form

    def steps_until(self, steps, until):
        """A loop body: its first request's reply of the form `until` ends it there."""
        first_send, first_reply = steps[0], steps[1]
        sent = fill(first_send[1], self.c.units, self.c.rotation)
        text = self.c.ask(sent)
        form, got = self.reply(text, first_reply[1], sent)
        if form is None:
            raise RuntimeError("stopping this exchange at the unparsed reply")
        self.judge(sent, text, form, got)
        if form == until:
            return form
        self.steps(steps[2:])
        return form

    def judge(self, sent, text, form, got):
        """What the reply must say beyond its form."""
        verb = sent.split()[0]
        print("     %s -> %s" % (sent, text))
        if verb in ("UNITS", "ROTATION", "CAPTURE"):
            check(text == "OK", "%s -> OK" % verb)
        elif verb == "DETECT":
            check(form[0] == "OK" and got.get("n", 0) >= 1,
                  "DETECT -> OK n with objects (%.0f ms after the last frame): %s" % (self.detect_ms, text))
            self.detected = got.get("n", 0)
        elif verb == "NEXT" and form[0] == "OBJECT":
            t, q = object_pose(got, "", self.c.units, self.c.rotation)
            gt, gq = object_pose(got, "g", self.c.units, self.c.rotation)
            self.objects.append((got["id"], got["score"], t, q, gt, gq))
            k = len(self.objects)
            check(0.0 <= got["score"] <= 1.0 and got["left"] == (self.detected or 0) - k,
                  "object %d: score in [0, 1], left %d" % (k, got["left"]))
        elif verb == "NEXT":
            check(len(self.objects) == self.detected,
                  "NO_OBJECTS after the %d objects DETECT counted (%d offered)" % (self.detected or 0, len(self.objects)))
        elif verb == "PICKED":
            check(got.get("left") == (self.detected or 0) - len(self.objects), "%s -> OK left: %s" % (sent, text))


def reference_objects(conn):
    """DETECT again on the same map in the default convention (m, xyzw): the objects as offered."""
    r = conn.ask("DETECT")
    out = []
    if not check(r.startswith("OK "), "reference connection (m, xyzw): DETECT -> %s" % r):
        return out
    form = "OBJECT id x y z qx qy qz qw score gx gy gz gqx gqy gqz gqw left".split()
    for _ in range(64):
        r = conn.ask("NEXT")
        got = matches(r.split(), form)
        if got is None:
            check(r == "NO_OBJECTS", "reference NEXT ends with NO_OBJECTS: " + r)
            break
        t, q = object_pose(got, "", "m", "xyzw")
        gt, gq = object_pose(got, "g", "m", "xyzw")
        out.append((got["id"], got["score"], t, q, gt, gq))
        conn.ask("PICKED OK")
    return out


def error_branch(name, steps, conn):
    """Before CAPTURE (no map): the program's DETECT must be answered in its ERR form and its NEXT
    with NO_OBJECTS, both among the forms it parses."""
    forms = {}
    flat = []
    for st in steps:
        flat += [st] + (st[2] if st[0] == "loop" else [])
    for a, b in zip(flat, flat[1:]):
        if a[0] == "send" and b[0] == "reply":
            forms.setdefault(a[1].split()[0], (a[1], b[1]))
    for verb in ("UNITS", "ROTATION"):
        if verb in forms:
            words = forms[verb][0].split()
            conn.ask(forms[verb][0])
            setattr(conn, "units" if verb == "UNITS" else "rotation", words[1])
    for verb, want in (("DETECT", "ERR"), ("NEXT", "NO_OBJECTS")):
        template, replies = forms[verb]
        sent = fill(template, conn.units, conn.rotation)
        r = conn.ask(sent)
        form = next((f for f in replies if matches(r.split(), f) is not None), None)
        check(form is not None and form[0] == want,
              "%s: before CAPTURE, %r -> %r, the program's %s form" % (name, sent, r, want))


def truth_positions():
    pos = []
    for line in open(os.path.join(RIG, "objects.txt")):
        w = line.split()
        if len(w) == 8 and not line.startswith("#"):
            pos.append(tuple(float(x) for x in w[1:4]))
    return pos


def run_exchange(path):
    name = os.path.basename(path)
    steps = read_exchange(path)
    work = os.path.join(WORK, name.replace(".", "_"))
    os.makedirs(work)
    log = open(os.path.join(work, "edgefused.log"), "w+")
    d = popen(EMU + [EDGEFUSED, "--set", "link.tcp_port=0", "--set", "robot.text_port=0", "--set", "link.serial=",
                     "--set", "console.echo=false", "--set", "calib.dir=" + os.path.join(work, "calib"),
                     "--set", "sensors.replay=" + RIG, "--set", "tracking.poses=known",
                     "--set", "sensors.replay_speed=%g" % REPLAY_SPEED],
              stdout=log, stderr=subprocess.STDOUT, cwd=work)
    info = wait_started(d, log, 120)
    if not check("ready" in info and "robot" in info, "%s: edgefused started on the replay of bin_rig_a" % name):
        log.seek(0)
        print(log.read())
        d.kill()
        return
    con = open_raw(info["console"])
    port = int(info["robot"].rsplit(":", 1)[1])
    error_branch(name, steps, Conn(port))
    run = Run(Conn(port), con)
    try:
        run.steps(steps)
    except (RuntimeError, EOFError, socket.timeout) as e:
        check(False, "%s: %s" % (name, e))
    units, rotation = run.c.units, run.c.rotation
    print("%s: %d objects offered in %s/%s; DETECT %.0f ms" % (name, len(run.objects), units, rotation, run.detect_ms))
    ref = reference_objects(Conn(port))
    same = len(ref) == len(run.objects) and len(ref) > 0
    worst_t, worst_r = 0.0, 0.0
    # the program's units/rotation against m/xyzw: each pose rounded to its printed decimals
    tol_t = 0.0005e-3 + 0.5e-6 if units == "mm" else 1e-6
    tol_r = 0.002 if rotation == "kuka_abc" else 0.001
    for a, b in zip(run.objects, ref):
        same = same and a[0] == b[0] and abs(a[1] - b[1]) < 1e-3
        for (ta, qa), (tb, qb) in (((a[2], a[3]), (b[2], b[3])), ((a[4], a[5]), (b[4], b[5]))):
            worst_t = max(worst_t, math.dist(ta, tb))
            worst_r = max(worst_r, quat_angle_deg(qa, qb))
    check(same and worst_t <= tol_t and worst_r <= tol_r,
          "%s: the %d objects in %s/%s agree with m/xyzw: ids and scores equal, worst %.2g m, %.2g deg" %
          (name, len(ref), units, rotation, worst_t, worst_r))
    truth = truth_positions()
    near = [min(math.dist(o[2], p) for p in truth) for o in run.objects]
    check(sum(1 for e in near if e < 0.010) >= 3,
          "%s: three or more objects lie within 10 mm of objects.txt's (frame and scale): %s mm" % (name, " ".join("%.1f" % (1e3 * e) for e in near)))
    sigterm_and_wait(d, 30)
    check(d.returncode == 0, "%s: edgefused stopped cleanly (exit %s)" % (name, d.returncode))


if not os.path.isfile(os.path.join(RIG, "objects.txt")):
    print("SKIP: no %s (the shared test data)" % RIG)
    sys.exit(0)
shutil.rmtree(WORK, ignore_errors=True)
os.makedirs(WORK)
exchanges = sorted(glob.glob(os.path.join(EXAMPLES, "*.exchange")))
check(len(exchanges) >= 2, "exchanges found: %s" % [os.path.basename(e) for e in exchanges])
t_start = time.monotonic()
for e in exchanges:
    run_exchange(e)
print("total %.1f s" % (time.monotonic() - t_start))
if failures:
    print("%d check(s) failed" % len(failures))
    sys.exit(1)
print("all checks passed")
