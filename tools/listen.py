#!/usr/bin/python3
"""Robot-controller side of the edgefuse pose link in plain Python.

Decodes the same stream as `edgefuse listen` with Google's protobuf package and a module generated
from the same schema (include/edgefuse/proto/edgefuse_link.proto) by protoc at start-up, to show
that an integrator can use any protobuf toolchain. Framing (docs/PROTOCOL.md): each frame is
COBS(payload + CRC-32 little-endian) followed by 0x00; UDP carries one frame per datagram.

  tools/listen.py (--serial DEV [--baud B] | --tcp HOST:PORT | --udp PORT | --file PATH)
                  [--csv] [--count N] [--timeout-s S]

Needs Debian's python3-protobuf and protobuf-compiler (run with /usr/bin/python3).
"""
import argparse
import importlib
import os
import select
import socket
import struct
import subprocess
import sys
import tempfile
import termios
import time
import zlib

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PROTO_DIR = os.path.join(REPO, "include", "edgefuse", "proto")


def load_pb2():
    """Generates edgefuse_link_pb2 with protoc into a temporary folder and imports it."""
    out = tempfile.mkdtemp(prefix="edgefuse_pb2_")
    try:
        subprocess.run(["protoc", "-I", PROTO_DIR, "--python_out=" + out,
                        os.path.join(PROTO_DIR, "edgefuse_link.proto")], check=True)
    except (OSError, subprocess.CalledProcessError) as e:
        sys.exit("listen.py: protoc failed (apt-get install protobuf-compiler): %s" % e)
    sys.path.insert(0, out)
    return importlib.import_module("edgefuse_link_pb2")


def cobs_decode(block):
    out = bytearray()
    i = 0
    while i < len(block):
        code = block[i]
        i += 1
        if code == 0 or i + code - 1 > len(block):
            return None
        out += block[i:i + code - 1]
        i += code - 1
        if code != 0xFF and i < len(block):
            out.append(0)
    return bytes(out)


class Stats:
    crc_errors = 0
    cobs_errors = 0
    bad_payloads = 0
    results = 0
    heartbeats = 0


def check_frame(block, stats):
    """Payload of one frame without its delimiter, or None (counted)."""
    data = cobs_decode(block)
    if data is None or len(data) < 4:
        stats.cobs_errors += 1
        return None
    payload, crc = data[:-4], struct.unpack("<I", data[-4:])[0]
    if zlib.crc32(payload) & 0xFFFFFFFF != crc:
        stats.crc_errors += 1
        return None
    return payload


STATUS = {0: "OK", 1: "NO_OBJECTS", 2: "FAILED", 3: "TRACKING_LOST"}
STATES = ["IDLE", "MAPPING", "LOCALIZE", "REPORT", "ERROR"]
TRACKING = ["OFF", "OK", "DEGRADED", "LOST"]


def f6(v):
    return "%.6f" % v


def print_message(m, csv):
    """Same lines as `edgefuse listen` (tests compare them)."""
    kind = m.WhichOneof("body")
    if kind == "result":
        r = m.result
        if not csv:
            print("result seq=%d stamp_us=%d status=%s objects=%d"
                  % (r.seq, r.stamp_us, STATUS.get(r.status, "UNKNOWN"), len(r.objects)))
        for o in r.objects:
            p, q, g, a = o.position_m, o.orientation, o.grasp_point_m, o.approach
            if csv:
                print(",".join([str(r.seq), str(r.stamp_us), str(o.id), f6(p.x), f6(p.y), f6(p.z),
                                f6(q.x), f6(q.y), f6(q.z), f6(q.w), "%.4f" % o.score]))
            else:
                print("  id=%d t=%s,%s,%s q=%s,%s,%s,%s score=%.4f grasp=%s,%s,%s approach=%.4f,%.4f,%.4f"
                      % (o.id, f6(p.x), f6(p.y), f6(p.z), f6(q.x), f6(q.y), f6(q.z), f6(q.w), o.score,
                         f6(g.x), f6(g.y), f6(g.z), a.x, a.y, a.z))
    elif kind == "heartbeat" and not csv:
        h = m.heartbeat
        print("heartbeat seq=%d stamp_us=%d protocol=%d state=%s tracking=%s fps=%.1f frames=%d drops=%d "
              "results=%d uptime_s=%d" % (h.seq, h.stamp_us, h.protocol_version,
                                          STATES[h.state] if h.state < len(STATES) else "UNKNOWN",
                                          TRACKING[h.tracking] if h.tracking < len(TRACKING) else "UNKNOWN",
                                          h.fps, h.frames, h.drops, h.results, h.uptime_s))
    sys.stdout.flush()


BAUDS = {9600: termios.B9600, 19200: termios.B19200, 38400: termios.B38400, 57600: termios.B57600,
         115200: termios.B115200, 230400: termios.B230400, 460800: termios.B460800, 921600: termios.B921600}


def open_serial(dev, baud):
    fd = os.open(dev, os.O_RDWR | os.O_NOCTTY)
    attrs = termios.tcgetattr(fd)
    attrs[0] = 0                                   # iflag: no translation, no flow control
    attrs[1] = 0                                   # oflag
    attrs[2] = termios.CS8 | termios.CREAD | termios.CLOCAL  # 8N1
    attrs[3] = 0                                   # lflag: raw, no echo
    attrs[4] = attrs[5] = BAUDS[baud]
    attrs[6][termios.VMIN] = 1
    attrs[6][termios.VTIME] = 0
    termios.tcsetattr(fd, termios.TCSANOW, attrs)
    return fd


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    src = ap.add_mutually_exclusive_group(required=True)
    src.add_argument("--serial")
    src.add_argument("--tcp", metavar="HOST:PORT")
    src.add_argument("--udp", type=int, metavar="PORT")
    src.add_argument("--file")
    ap.add_argument("--baud", type=int, default=115200, choices=sorted(BAUDS))
    ap.add_argument("--csv", action="store_true")
    ap.add_argument("--count", type=int, default=0)
    ap.add_argument("--timeout-s", type=float, default=0)
    a = ap.parse_args()
    pb2 = load_pb2()
    stats = Stats()

    sock = None
    fd = None
    if a.serial:
        fd = open_serial(a.serial, a.baud)
    elif a.tcp:
        host, _, port = a.tcp.rpartition(":")
        sock = socket.create_connection((host or "127.0.0.1", int(port)))
    elif a.udp:
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        sock.bind(("", a.udp))
    else:
        fd = os.open(a.file, os.O_RDONLY)

    def handle(payload):
        m = pb2.Message()
        try:
            m.ParseFromString(payload)
        except Exception:  # noqa: BLE001 - a malformed payload is counted, not fatal
            stats.bad_payloads += 1
            return
        if m.WhichOneof("body") == "result":
            stats.results += 1
        elif m.WhichOneof("body") == "heartbeat":
            stats.heartbeats += 1
        print_message(m, a.csv)

    block = bytearray()
    last = time.monotonic()
    rc = 0
    while not a.count or stats.results < a.count:
        waitable = sock if sock is not None else fd
        if not a.file:
            ready, _, _ = select.select([waitable], [], [], 0.1)
            if not ready:
                if a.timeout_s and time.monotonic() - last > a.timeout_s:
                    print("listen.py: no valid frame for %.1f s" % a.timeout_s, file=sys.stderr)
                    rc = 1
                    break
                continue
        data = sock.recv(65536) if sock is not None else os.read(fd, 65536)
        if not data:
            if not a.file:
                print("listen.py: the link closed", file=sys.stderr)
                rc = 1
            break
        if a.udp:
            payload = check_frame(data.rstrip(b"\0"), stats)
            if payload is not None:
                last = time.monotonic()
                handle(payload)
            continue
        for b in data:
            if b != 0:
                block.append(b)
                continue
            if block:
                payload = check_frame(bytes(block), stats)
                block.clear()
                if payload is not None:
                    last = time.monotonic()
                    handle(payload)
                    if a.count and stats.results >= a.count:
                        break
    print("listen.py: %d results, %d heartbeats, crc_errors=%d cobs_errors=%d bad_payloads=%d"
          % (stats.results, stats.heartbeats, stats.crc_errors, stats.cobs_errors, stats.bad_payloads),
          file=sys.stderr)
    if a.count and stats.results < a.count:
        rc = 1
    return rc


if __name__ == "__main__":
    sys.exit(main())
