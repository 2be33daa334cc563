#!/usr/bin/python3
"""tools/robot/edgefuse_robot.py against a fake text port on loopback (a thread answering scripted
replies): every request's line and the parsed replies, the per-connection conventions, error replies,
timeouts, garbled replies and a closed connection named with the request.

usage: robot_client_test.py
"""
import os
import socket
import sys
import threading
import unittest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tools", "robot"))
import edgefuse_robot as er  # noqa: E402


class FakeTextPort:
    """Accepts one connection; records every line; answers each with the first reply whose key the
    line starts with (None: no reply, "CLOSE": closes the connection)."""

    def __init__(self, replies):
        self.replies = replies
        self.lines = []
        self.srv = socket.socket()
        self.srv.bind(("127.0.0.1", 0))
        self.srv.listen(1)
        self.port = self.srv.getsockname()[1]
        self.thread = threading.Thread(target=self.serve, daemon=True)
        self.thread.start()

    def serve(self):
        conn, _ = self.srv.accept()
        buf = b""
        with conn:
            while True:
                chunk = conn.recv(4096)
                if not chunk:
                    return
                buf += chunk
                while b"\n" in buf:
                    line, _, buf = buf.partition(b"\n")
                    line = line.decode()
                    self.lines.append(line)
                    reply = next((r for k, r in self.replies if line.startswith(k)), "ERR 5 UNKNOWN_COMMAND unknown command")
                    if reply == "CLOSE":
                        return
                    if reply is not None:
                        conn.sendall(reply.encode() + b"\n")

    def close(self):
        self.srv.close()


OBJ_M = ("OBJECT 3 0.412000 -0.105000 0.031000 0.0000000 0.0000000 0.2588191 0.9659259 0.9300 "
         "0.412000 -0.105000 0.041000 0.0000000 0.0000000 0.2588191 0.9659259 2")
OBJ_ABC = "OBJECT 2 475.000 20.000 45.000 0.0000 0.0000 90.0000 0.8800 475.000 20.000 45.000 0.0000 0.0000 90.0000 1"


class RobotClientTest(unittest.TestCase):
    def start(self, replies, timeout_s=2.0):
        self.fake = FakeTextPort(replies)
        self.addCleanup(self.fake.close)
        self.robot = er.RobotClient().connect("127.0.0.1", self.fake.port, timeout_s=timeout_s)
        self.addCleanup(self.robot.close)
        return self.robot

    def test_picking_cycle(self):
        r = self.start([("CAPTURE", "OK"), ("POSE", None), ("DETECT", "OK 3"), ("NEXT", OBJ_M), ("PICKED", "OK 2"),
                        ("STATUS", "OK REPORT ok 3 2 0"), ("STOP", "OK")])
        r.capture((0.4, 0, 0.6, 0, 0, 0, 1))
        for i in range(3):
            r.pose((0.4 + 1e-4 * i, 0, 0.6, 0, 0, 0, 1))
        self.assertEqual(r.detect(), 3)
        o = r.next_object()
        self.assertEqual((o.id, o.score, o.left), (3, 0.93, 2))
        self.assertEqual(o.pose, (0.412, -0.105, 0.031, 0.0, 0.0, 0.2588191, 0.9659259))
        self.assertAlmostEqual(o.grasp[2], 0.041)
        self.assertEqual(r.picked(True), 2)
        self.assertEqual(r.status(), er.Status("REPORT", "ok", 3, 2, 0))
        r.stop()
        self.assertEqual(self.fake.lines[0], "CAPTURE 0.4000000 0.0000000 0.6000000 0.0000000 0.0000000 0.0000000 1.0000000")
        self.assertEqual(self.fake.lines[2], "POSE 0.4001000 0.0000000 0.6000000 0.0000000 0.0000000 0.0000000 1.0000000")
        self.assertEqual(self.fake.lines[4:], ["DETECT", "NEXT", "PICKED OK", "STATUS", "STOP"])

    def test_no_objects_and_async(self):
        r = self.start([("DETECT_ASYNC", "OK"), ("DETECT_STATUS", "RUNNING"), ("DETECT", "NO_OBJECTS"),
                        ("NEXT", "NO_OBJECTS"), ("PICKED", "OK 0")])
        self.assertEqual(r.detect(pose=(0, 0, 0.5, 0, 0, 0, 1)), 0)
        self.assertIsNone(r.next_object())
        r.detect_async()
        self.assertIsNone(r.detect_status())
        self.assertEqual(r.picked(False), 0)
        self.assertEqual(self.fake.lines[0], "DETECT 0.0000000 0.0000000 0.5000000 0.0000000 0.0000000 0.0000000 1.0000000")
        self.assertEqual(self.fake.lines[-1], "PICKED FAILED")

    def test_units_and_rotation(self):
        r = self.start([("UNITS", "OK"), ("ROTATION", "OK"), ("NEXT", OBJ_ABC), ("POSE", None),
                        ("HANDEYE ADD", "OK 4"), ("HANDEYE SOLVE", "OK 1.000 2.000 3.000 10.0000 0.0000 0.0000 0.4410 0.0320"),
                        ("HANDEYE SAVE", "OK"), ("HANDEYE RESET", "OK"), ("CALIBRATION", "OK 1.000 2.000 3.000 10.0000 0.0000 0.0000")])
        r.set_units("mm")
        r.set_rotation("kuka_abc")
        o = r.next_object()
        self.assertEqual((o.id, o.pose, o.left), (2, (475.0, 20.0, 45.0, 0.0, 0.0, 90.0), 1))
        r.pose((1, 2, 3, 10, 0, 0))
        self.assertEqual(r.handeye_add((1, 2, 3, 10, 0, 0)), 4)
        he = r.handeye_solve()
        self.assertEqual((he.pose[3], he.residual_mm, he.residual_deg), (10.0, 0.441, 0.032))
        r.handeye_save()
        r.handeye_reset()
        self.assertEqual(r.calibration(), (1.0, 2.0, 3.0, 10.0, 0.0, 0.0))
        self.assertEqual(self.fake.lines[:2], ["UNITS mm", "ROTATION kuka_abc"])
        self.assertEqual(self.fake.lines[3], "POSE 1.0000 2.0000 3.0000 10.0000000 0.0000000 0.0000000")
        with self.assertRaises(ValueError):
            r.pose((0, 0, 0, 0, 0, 0, 1))  # 7 numbers where kuka_abc poses have 6
        with self.assertRaises(ValueError):
            r.set_units("inch")

    def test_error_reply_names_the_request(self):
        r = self.start([("HANDEYE SOLVE", "ERR 3 NOT_CALIBRATED 0 stations: at least 3, rotated about 2 axes"),
                        ("NEXT", "ERR 2 BUSY detect running")])
        with self.assertRaises(er.ReplyError) as c:
            r.handeye_solve()
        e = c.exception
        self.assertEqual((e.code, e.name, e.request), (3, "NOT_CALIBRATED", "HANDEYE SOLVE"))
        self.assertIn("0 stations", e.reason)
        self.assertIn("HANDEYE SOLVE", str(e))
        with self.assertRaises(er.ReplyError) as c:
            r.next_object()
        self.assertEqual(c.exception.name, "BUSY")

    def test_garbled_replies(self):
        r = self.start([("DETECT", "OK three"), ("NEXT", "OBJECT 1 0.1 0.2"), ("STATUS", "OK MAPPING"),
                        ("PICKED", "YES"), ("CAPTURE", "OK 1")])
        for call, name in [(r.detect, "DETECT"), (r.next_object, "NEXT"), (r.status, "STATUS"), (r.picked, "PICKED OK"),
                           (lambda: r.capture((0, 0, 0, 0, 0, 0, 1)), "CAPTURE")]:
            with self.assertRaises(er.GarbledReply) as c:
                call()
            self.assertTrue(c.exception.request.startswith(name), c.exception.request)

    def test_timeout_and_closed(self):
        r = self.start([("STATUS", None), ("STOP", "CLOSE")], timeout_s=0.3)
        with self.assertRaises(er.RobotTimeout) as c:
            r.status()
        self.assertEqual(c.exception.request, "STATUS")
        self.assertIn("STATUS", str(c.exception))
        with self.assertRaises(er.ConnectionClosed) as c:
            r.stop()
        self.assertEqual(c.exception.request, "STOP")

    def test_connect_refused(self):
        s = socket.socket()
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
        s.close()  # nobody listens there
        with self.assertRaises(er.ConnectionClosed):
            er.RobotClient().connect("127.0.0.1", port, timeout_s=1)


if __name__ == "__main__":
    unittest.main(verbosity=2)
