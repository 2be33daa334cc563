"""A robot-side client of edgefused's text profile (docs/PROTOCOL.md, "Text profile"), standard
library only: one TCP connection to `robot.text_port`, one request per line, one reply per line
(POSE has none).

    from edgefuse_robot import RobotClient
    robot = RobotClient().connect("127.0.0.1", 5557, timeout_s=10)
    robot.capture((0.0, 0.0, 0.7, 1, 0, 0, 0))          # start a new map
    robot.pose((0.0, 0.001, 0.7, 1, 0, 0, 0))           # streamed flange poses, no reply
    n = robot.detect()                                  # objects found (0: NO_OBJECTS)
    while (obj := robot.next_object()) is not None:
        print(obj.id, obj.pose, obj.score)
        robot.picked(True)

A pose is a sequence of numbers in the connection's convention: x y z (metres, or millimetres after
set_units("mm")) then the rotation (set_rotation: "xyzw" / "wxyz" quaternions, 4 numbers;
"axisangle" rotation vector in radians or "kuka_abc" degrees, 3 numbers). Replies come back as
tuples of floats in the same convention.

Errors raise RobotError subclasses that name the request: ReplyError (an `ERR code NAME reason`
reply; .code, .name, .reason), RobotTimeout (no reply in time), GarbledReply (a reply that does not
parse as the request's answer), and ConnectionClosed.
"""
import collections
import socket
import time

__all__ = ["RobotClient", "NextObject", "Status", "HandEye", "RobotError", "ReplyError", "RobotTimeout",
           "GarbledReply", "ConnectionClosed", "ROTATION_SIZES"]

#: numbers of the rotation part of a pose per ROTATION convention
ROTATION_SIZES = {"xyzw": 4, "wxyz": 4, "axisangle": 3, "kuka_abc": 3}

#: NEXT: the object's id, pose, score, the grasp pose and how many objects are left after it
NextObject = collections.namedtuple("NextObject", "id pose score grasp left")
#: STATUS: state (IDLE, MAPPING, LOCALIZE, REPORT), tracking (off, ok, degraded, lost), the objects of
#: the last detect, how many of them are left to offer, hand-eye stations held
Status = collections.namedtuple("Status", "state tracking objects left stations")
#: HANDEYE SOLVE: T_flange_camera and the RMS station residuals
HandEye = collections.namedtuple("HandEye", "pose residual_mm residual_deg")


class RobotError(Exception):
    """Any failed request; .request is the line that was sent (without the line end)."""

    def __init__(self, request, message):
        super().__init__("%s: %s" % (request, message))
        self.request = request


class ReplyError(RobotError):
    """edgefused answered `ERR code NAME reason`."""

    def __init__(self, request, reply):
        words = reply.split(None, 3)
        self.code = int(words[1]) if len(words) > 1 and words[1].isdigit() else -1
        self.name = words[2] if len(words) > 2 else ""
        self.reason = words[3] if len(words) > 3 else ""
        self.reply = reply
        super().__init__(request, "edgefused answered %r" % reply)


class RobotTimeout(RobotError):
    """No (complete) reply line within the timeout."""


class GarbledReply(RobotError):
    """A reply line that is not an answer to the request."""

    def __init__(self, request, reply, why):
        self.reply = reply
        super().__init__(request, "unexpected reply %r (%s)" % (reply, why))


class ConnectionClosed(RobotError):
    """edgefused closed the connection (or it was never opened)."""


def _numbers(request, reply, words, n):
    if len(words) != n:
        raise GarbledReply(request, reply, "%d numbers expected, got %d" % (n, len(words)))
    try:
        return tuple(float(w) for w in words)
    except ValueError:
        raise GarbledReply(request, reply, "not a number") from None


def _int(request, reply, word):
    try:
        v = int(word)
    except ValueError:
        raise GarbledReply(request, reply, "%r is not a count" % word) from None
    if v < 0:
        raise GarbledReply(request, reply, "negative count")
    return v


class RobotClient:
    """One connection to edgefused's text port. Not thread-safe: one request at a time (POSE lines
    may be sent between requests)."""

    def __init__(self):
        self.sock = None
        self.timeout_s = 10.0
        self.units = "m"
        self.rotation = "xyzw"
        self._buf = b""

    # --- connection -----------------------------------------------------------------------------
    def connect(self, host, port, timeout_s=10.0, units="m", rotation="xyzw"):
        """Connects; timeout_s bounds the connect and every reply wait (detect may pass its own).
        units / rotation: the convention the connection starts with (edgefused's robot.units /
        robot.rotation; "m" / "xyzw" unless configured otherwise). Returns self."""
        self.close()
        self.timeout_s = float(timeout_s)
        try:
            self.sock = socket.create_connection((host, int(port)), timeout=self.timeout_s)
        except OSError as e:
            raise ConnectionClosed("connect %s:%s" % (host, port), str(e)) from None
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._buf = b""
        self.units = units
        self.rotation = rotation
        return self

    def close(self):
        if self.sock is not None:
            self.sock.close()
            self.sock = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # --- the line layer -------------------------------------------------------------------------
    def send_line(self, line):
        """Sends one line (no reply is read)."""
        if self.sock is None:
            raise ConnectionClosed(line, "not connected")
        try:
            self.sock.sendall(line.encode() + b"\n")
        except OSError as e:
            raise ConnectionClosed(line, str(e)) from None

    def _read_line(self, request, timeout_s):
        end = time.monotonic() + timeout_s
        while b"\n" not in self._buf:
            left = end - time.monotonic()
            if left <= 0:
                raise RobotTimeout(request, "no reply within %.1f s" % timeout_s)
            self.sock.settimeout(left)
            try:
                chunk = self.sock.recv(4096)
            except socket.timeout:
                raise RobotTimeout(request, "no reply within %.1f s" % timeout_s) from None
            except OSError as e:
                raise ConnectionClosed(request, str(e)) from None
            if not chunk:
                raise ConnectionClosed(request, "edgefused closed the connection")
            self._buf += chunk
        line, _, self._buf = self._buf.partition(b"\n")
        try:
            return line.decode("ascii").rstrip("\r")
        except UnicodeDecodeError:
            raise GarbledReply(request, line, "not ASCII") from None

    def request(self, line, timeout_s=None):
        """Sends a request line and returns its reply line; an `ERR ...` reply raises ReplyError."""
        self.send_line(line)
        reply = self._read_line(line, self.timeout_s if timeout_s is None else timeout_s)
        if reply.startswith("ERR"):
            raise ReplyError(line, reply)
        return reply

    def _ok(self, line, timeout_s=None):
        reply = self.request(line, timeout_s)
        if reply != "OK":
            raise GarbledReply(line, reply, "OK expected")

    def _ok_count(self, line):
        reply = self.request(line)
        w = reply.split()
        if len(w) != 2 or w[0] != "OK":
            raise GarbledReply(line, reply, "OK n expected")
        return _int(line, reply, w[1])

    # --- poses ----------------------------------------------------------------------------------
    def pose_size(self):
        return 3 + ROTATION_SIZES[self.rotation]

    def format_pose(self, pose):
        """The pose's words: translations with 4 (mm) or 7 (m) decimals, rotations with 7."""
        p = [float(v) for v in pose]
        if len(p) != self.pose_size():
            raise ValueError("a pose in %s/%s is %d numbers, got %d" % (self.units, self.rotation, self.pose_size(), len(p)))
        tfmt = "%.4f" if self.units == "mm" else "%.7f"
        return " ".join([tfmt % v for v in p[:3]] + ["%.7f" % v for v in p[3:]])

    def _pose_words(self, request, reply, words):
        return _numbers(request, reply, words, self.pose_size())

    # --- requests -------------------------------------------------------------------------------
    def capture(self, pose):
        """CAPTURE: a new map, mapping starts; pose is the flange's pose now."""
        self._ok("CAPTURE " + self.format_pose(pose))

    def pose(self, pose):
        """POSE: one streamed flange pose update (no reply; edgefused stamps it on arrival)."""
        self.send_line("POSE " + self.format_pose(pose))

    def detect(self, pose=None, timeout_s=120.0):
        """DETECT [pose]: waits for the localisation; returns the number of objects (0 for
        NO_OBJECTS)."""
        line = "DETECT" + ("" if pose is None else " " + self.format_pose(pose))
        return self._detect_reply(line, self.request(line, timeout_s))

    def detect_async(self, pose=None):
        """DETECT_ASYNC [pose]: starts the localisation, answered at once."""
        self._ok("DETECT_ASYNC" + ("" if pose is None else " " + self.format_pose(pose)))

    def detect_status(self):
        """DETECT_STATUS: None while running, else the number of objects (0 for NO_OBJECTS)."""
        reply = self.request("DETECT_STATUS")
        if reply == "RUNNING":
            return None
        return self._detect_reply("DETECT_STATUS", reply)

    @staticmethod
    def _detect_reply(line, reply):
        if reply == "NO_OBJECTS" or reply.startswith("NO_OBJECTS "):
            return 0
        w = reply.split()
        if len(w) != 2 or w[0] != "OK":
            raise GarbledReply(line, reply, "OK n or NO_OBJECTS expected")
        return _int(line, reply, w[1])

    def next_object(self):
        """NEXT: the next object (NextObject: id, pose, score, grasp pose, left), or None for
        NO_OBJECTS."""
        reply = self.request("NEXT")
        if reply == "NO_OBJECTS":
            return None
        w = reply.split()
        n = self.pose_size()
        if len(w) != 2 * n + 4 or w[0] != "OBJECT":
            raise GarbledReply("NEXT", reply, "OBJECT id pose score grasp left with %d-number poses expected" % n)
        oid = _int("NEXT", reply, w[1])
        pose = self._pose_words("NEXT", reply, w[2:2 + n])
        score = _numbers("NEXT", reply, w[2 + n:3 + n], 1)[0]
        grasp = self._pose_words("NEXT", reply, w[3 + n:3 + 2 * n])
        left = _int("NEXT", reply, w[3 + 2 * n])
        return NextObject(oid, pose, score, grasp, left)

    def picked(self, ok=True):
        """PICKED OK|FAILED for the object NEXT offered; returns how many are left."""
        return self._ok_count("PICKED " + ("OK" if ok else "FAILED"))

    def stop(self):
        """STOP: mapping stops."""
        self._ok("STOP")

    def status(self):
        """STATUS -> Status(state, tracking, objects, left, stations)."""
        reply = self.request("STATUS")
        w = reply.split()
        if len(w) != 6 or w[0] != "OK":
            raise GarbledReply("STATUS", reply, "OK state tracking objects left stations expected")
        return Status(w[1], w[2], *(_int("STATUS", reply, v) for v in w[3:6]))

    def set_units(self, units):
        """UNITS m|mm for this connection (poses sent and received)."""
        if units not in ("m", "mm"):
            raise ValueError("units are m or mm, not %r" % units)
        self._ok("UNITS " + units)
        self.units = units

    def set_rotation(self, rotation):
        """ROTATION xyzw|wxyz|axisangle|kuka_abc for this connection."""
        if rotation not in ROTATION_SIZES:
            raise ValueError("rotation is one of %s, not %r" % ("|".join(ROTATION_SIZES), rotation))
        self._ok("ROTATION " + rotation)
        self.rotation = rotation

    def handeye_add(self, pose):
        """HANDEYE ADD pose: a station (the flange's pose while still); returns the stations held."""
        return self._ok_count("HANDEYE ADD " + self.format_pose(pose))

    def handeye_solve(self):
        """HANDEYE SOLVE -> HandEye(T_flange_camera pose, residual_mm, residual_deg)."""
        reply = self.request("HANDEYE SOLVE")
        w = reply.split()
        n = self.pose_size()
        if len(w) != n + 3 or w[0] != "OK":
            raise GarbledReply("HANDEYE SOLVE", reply, "OK pose res_mm res_deg expected")
        res = _numbers("HANDEYE SOLVE", reply, w[n + 1:], 2)
        return HandEye(self._pose_words("HANDEYE SOLVE", reply, w[1:n + 1]), res[0], res[1])

    def handeye_save(self):
        """HANDEYE SAVE: the solved mounting into the calibration store."""
        self._ok("HANDEYE SAVE")

    def handeye_reset(self):
        """HANDEYE RESET: the stations are dropped."""
        self._ok("HANDEYE RESET")

    def calibration(self):
        """CALIBRATION: the stored T_flange_rig (ReplyError NOT_CALIBRATED when none is stored)."""
        reply = self.request("CALIBRATION")
        w = reply.split()
        if len(w) != self.pose_size() + 1 or w[0] != "OK":
            raise GarbledReply("CALIBRATION", reply, "OK pose expected")
        return self._pose_words("CALIBRATION", reply, w[1:])
