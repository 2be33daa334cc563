#!/usr/bin/python3
"""End-to-end on loopback: the robot's requests to the firmware with exact, fixed poses
(edgefused_exact_poses). Over the text port: CAPTURE -> DETECT -> NEXT until NO_OBJECTS with
PICKED OK/FAILED, poses checked against the simulated bin in m/xyzw and mm/wxyz; 250 Hz POSE
streaming without replies; malformed lines answered with ERR and counted; a client that stops
reading (its socket full) while another keeps working; the NEXT round trip timed. Over the
link's TCP port: protobuf requests (framed like every message) answered with the request's id,
a garbled frame answered with REPLY_BAD_REQUEST.

usage: robot_link_e2e.py [--emulator CMD] [--time-factor F] EDGEFUSED LISTEN_PY WORKDIR
"""
import importlib.util
import os
import select
import shutil
import signal
import socket
import struct
import subprocess
import sys
import time
import zlib

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from edgefused_helpers import TextClient, check, emulation, failures, open_raw, popen, wait_started  # noqa: E402

EMU, SLOW = emulation(sys.argv)
EDGEFUSED, LISTEN_PY, WORK = sys.argv[1:4]
# tests/firmware/exact_pose_pipeline.cpp: kSimObjects (id, t, q, score), in picking order
TRUTH = [
    (1, (0.412, -0.105, 0.031), (0.0, 0.0, 0.2588190, 0.9659258), 0.93),
    (2, (0.475, 0.020, 0.045), (0.7071068, 0.0, 0.0, 0.7071068), 0.88),
    (3, (0.390, 0.110, 0.025), (0.0, 0.0, 0.0, 1.0), 0.61),
]


def check_object(reply, index, mm=False, wxyz=False):
    w = reply.split()
    oid, t, q, score = TRUTH[index]
    scale = 1000.0 if mm else 1.0
    want_q = (q[3], q[0], q[1], q[2]) if wxyz else q
    want = [v * scale for v in t] + list(want_q)
    tol = [1e-5 * scale] * 3 + [1e-5] * 4
    ok = len(w) == 18 and w[0] == "OBJECT" and int(w[1]) == oid and abs(float(w[9]) - score) < 1e-3
    # object pose, then the grasp pose (the object pose: no grasp planner yet), then the count left
    ok = ok and all(abs(float(a) - b) <= e for a, b, e in zip(w[2:9], want, tol))
    ok = ok and all(abs(float(a) - b) <= e for a, b, e in zip(w[10:17], want, tol))
    ok = ok and int(w[17]) == len(TRUTH) - 1 - index
    check(ok, "NEXT offers object %d with its pose%s: %s" % (oid, " (mm, wxyz)" if mm else "", reply))


def cobs_encode(data):
    out, block = bytearray(), bytearray()
    for b in data:
        if b == 0:
            out += bytes([len(block) + 1]) + block
            block = bytearray()
        else:
            block.append(b)
            if len(block) == 254:
                out += bytes([255]) + block
                block = bytearray()
    out += bytes([len(block) + 1]) + block
    return bytes(out)


def frame(payload):
    return cobs_encode(payload + struct.pack("<I", zlib.crc32(payload) & 0xFFFFFFFF)) + b"\0"


def replies(read, listen, pb2, want, timeout):
    """Protobuf replies from the link's stream (results and heartbeats skipped) until `want` arrived;
    read() returns the bytes that came in a short wait (b"" for none)."""
    got, buf, end = [], b"", time.monotonic() + timeout
    while len(got) < want and time.monotonic() < end:
        buf += read()
        while b"\0" in buf:
            block, _, buf = buf.partition(b"\0")
            data = listen.cobs_decode(block) if block else None
            if not data or len(data) < 4 or zlib.crc32(data[:-4]) & 0xFFFFFFFF != struct.unpack("<I", data[-4:])[0]:
                continue
            m = pb2.Message()
            m.ParseFromString(data[:-4])
            if m.WhichOneof("body") == "reply":
                got.append(m.reply)
    return got


shutil.rmtree(WORK, ignore_errors=True)
os.makedirs(WORK, exist_ok=True)
log = open(os.path.join(WORK, "edgefused.log"), "w+")
d = popen([*EMU, EDGEFUSED, "--set", "link.tcp_port=0", "--set", "robot.text_port=0", "--set", "link.serial=pty",
           "--set", "console.serial=", "--set", "link.heartbeat_ms=100",
           "--set", "calib.dir=" + os.path.join(WORK, "calib")], stdout=log, stderr=subprocess.STDOUT, cwd=WORK)
info = wait_started(d, log, 10)
check("ready" in info and "robot" in info, "edgefused started and printed 'robot: HOST:PORT': %s" % info.get("robot"))
if "ready" not in info or "robot" not in info:
    d.kill()
    sys.exit(1)
text_port = int(info["robot"].rsplit(":", 1)[1])
link_port = int(info["tcp"].rsplit(":", 1)[1])

# --- a client that stops reading: it floods requests and never reads its replies --------------
stalled = socket.create_connection(("127.0.0.1", text_port))
stalled.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
stalled.setblocking(False)
flood = b"STATUS\n" * 4000
sent = 0
end = time.monotonic() + 5 * SLOW
while sent < len(flood) and time.monotonic() < end:
    try:
        sent += stalled.send(flood[sent:])
    except BlockingIOError:
        time.sleep(0.01)
stalled_pb = socket.create_connection(("127.0.0.1", link_port))  # never reads the heartbeats either
stalled_pb.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)

# --- the picking cycle over the text port ------------------------------------------------------
a = TextClient(text_port, 10)
check(a.ask("CAPTURE 0.4 0 0.6 0 0 0 1") == "OK", "CAPTURE -> OK")
for i in range(500):  # 2 s of a robot's pose stream at 250 Hz, sent at once: no replies
    a.s.sendall(b"POSE %.4f,0,0.6, 0,0,0,1\n" % (0.4 + 1e-4 * i))
r = a.ask("STATUS")
check(r.startswith("OK MAPPING"), "STATUS after 500 POSE lines is the next line: " + r)
t0 = time.monotonic()
r = a.ask("DETECT")
check(r == "OK 3", "DETECT -> OK 3 (%.0f ms): %s" % (1000 * (time.monotonic() - t0), r))
rtt = []
for i in range(len(TRUTH)):
    t0 = time.monotonic()
    r = a.ask("NEXT")
    rtt.append(time.monotonic() - t0)
    check_object(r, i)
    r = a.ask("PICKED OK" if i != 1 else "PICKED FAILED")
    check(r == "OK %d" % (len(TRUTH) - 1 - i), "PICKED -> OK left: " + r)
check(a.ask("NEXT") == "NO_OBJECTS", "NEXT after the last object -> NO_OBJECTS")
rtt.sort()
print("NEXT round trip: median %.2f ms, max %.2f ms" % (1000 * rtt[len(rtt) // 2], 1000 * rtt[-1]))
check(rtt[len(rtt) // 2] < 0.05 * SLOW, "NEXT round trip median below 50 ms while a client stalls")

# --- per-connection units and rotation; asynchronous detect ------------------------------------
check(a.ask("UNITS mm") == "OK" and a.ask("ROTATION wxyz") == "OK", "UNITS mm, ROTATION wxyz -> OK")
check(a.ask("DETECT_ASYNC") == "OK", "DETECT_ASYNC -> OK at once")
r = a.ask("DETECT_STATUS")
end = time.monotonic() + 10 * SLOW
while r == "RUNNING" and time.monotonic() < end:
    time.sleep(0.02)
    r = a.ask("DETECT_STATUS")
check(r == "OK 3", "DETECT_STATUS polled to OK 3: " + r)
check_object(a.ask("NEXT"), 0, mm=True, wxyz=True)

# --- malformed lines: each answered with ERR, the connection and the state kept ----------------
bad = [("CAPTURE 1 2", "ERR 4 BAD_REQUEST"), ("JUMP", "ERR 5 UNKNOWN_COMMAND"), ("PICKED MAYBE", "ERR 4"),
       ("UNITS inch", "ERR 4"), ("X" * 300, "ERR 4 BAD_REQUEST line longer"), ("\x01\x02\x7f", "ERR 5"),
       ("HANDEYE SOLVE", "ERR 3 NOT_CALIBRATED 0 stations"), ("HANDEYE ADD 0 0 0 1 0 0 0", "ERR 6 FAILED no camera pose")]
for line, want in bad:
    r = a.ask(line)
    check(r.startswith(want), "%r -> %s" % (line[:20], r))
r = a.ask("STATUS")
check(r.startswith("OK MAPPING ok 3 2 0"), "state kept after the bad lines: " + r)

# --- protobuf requests on the link's TCP port ----------------------------------------------------
spec = importlib.util.spec_from_file_location("listen", LISTEN_PY)
listen = importlib.util.module_from_spec(spec)
spec.loader.exec_module(listen)
pb2 = listen.load_pb2()
p = socket.create_connection(("127.0.0.1", link_port))
msg = pb2.Message()
msg.request.id = 41
msg.request.command = pb2.COMMAND_STATUS
stream = frame(msg.SerializeToString())
msg.request.id = 42
msg.request.command = pb2.COMMAND_NEXT
stream += frame(msg.SerializeToString())
garbled = bytearray(frame(msg.SerializeToString()))
garbled[3] ^= 0x10
stream += bytes(garbled)
msg.request.id = 43
msg.request.command = 77  # unknown to this board
stream += frame(msg.SerializeToString())
p.sendall(stream)
p.settimeout(0.2)


def read_tcp():
    try:
        return p.recv(65536)
    except socket.timeout:
        return b""


got = replies(read_tcp, listen, pb2, 4, 10 * SLOW)
check([g.id for g in got] == [41, 42, 0, 43], "protobuf replies carry the request ids: %s" % [g.id for g in got])
if len(got) == 4:
    check(got[0].status == pb2.REPLY_OK and got[0].state == pb2.STATE_MAPPING, "STATUS reply")
    check(got[1].status == pb2.REPLY_OK and got[1].object.id == 2 and got[1].left == 1,
          "NEXT reply: object 2, 1 left (object 1 was offered over the text port)")
    check(got[2].status == pb2.REPLY_BAD_REQUEST and "CRC" in got[2].message, "garbled frame -> REPLY_BAD_REQUEST")
    check(got[3].status == pb2.REPLY_UNKNOWN_COMMAND, "unknown command -> REPLY_UNKNOWN_COMMAND")

# --- a protobuf request on the link's serial line (a pseudo-terminal here) ------------------------
serial = open_raw(info["link"])
msg = pb2.Message()
msg.request.id = 51
msg.request.command = pb2.COMMAND_DETECT_STATUS
os.write(serial, frame(msg.SerializeToString()))


def read_serial():
    r, _, _ = select.select([serial], [], [], 0.2)
    return os.read(serial, 4096) if r else b""


got = replies(read_serial, listen, pb2, 1, 10 * SLOW)
check(len(got) == 1 and got[0].id == 51 and got[0].status == pb2.REPLY_OK and got[0].count == 3,
      "DETECT_STATUS on the serial line -> REPLY_OK, 3 objects")
os.close(serial)

# The stalled clients still hold their connections; the pipeline went on (heartbeats every 100 ms).
check(a.ask("STOP") == "OK", "STOP -> OK")
d.send_signal(signal.SIGTERM)
d.wait(timeout=10 * SLOW)
log.seek(0)
out = log.read()
robot_line = [l for l in out.splitlines() if l.startswith("robot: ") and "requests" in l]
print(robot_line[0] if robot_line else out[-2000:])
if robot_line:
    w = robot_line[0].replace("(", " ").replace(",", " ").split()
    pose_updates, bad_count, unknown, refused = int(w[3]), int(w[6]), int(w[8]), int(w[10])
    check(pose_updates >= 500 and refused == 0, "%d pose updates accepted, %d refused" % (pose_updates, refused))
    check(bad_count >= 5 and unknown >= 3, "bad requests counted (%d) and unknown commands (%d)" % (bad_count, unknown))
check(d.returncode == 0, "SIGTERM stops edgefused cleanly")
stalled.close()
stalled_pb.close()
p.close()
print("FAILED: %d checks" % len(failures) if failures else "all checks passed")
sys.exit(1 if failures else 0)
