"""Helpers shared by the edgefused end-to-end tests (edgefused_e2e.py, edgefused_fusion_e2e.py, the
robot tests): the options of a run under an emulator, the programs they start (stopped when the
test ends, also on an exception), edgefused's start-up lines, the console pseudo-terminal in raw
mode, one console command and its reply, a line client of the robot's text port, waiting for a replayed recording to be mapped, the
process's VmData, and the checks' record."""
import atexit
import os
import re
import shlex
import signal
import socket
import subprocess
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tools", "robot"))
import console  # noqa: E402

# The tests open the console pty as the robot tools do.
open_raw = console.open_raw

# Waits (not tolerances) are multiplied by this under an emulator (emulation()).
TIME_FACTOR = 1.0


def emulation(argv):
    """Takes the options of a run under an emulator out of argv (the ARM builds run their tests
    under qemu-user) and returns (prefix, factor):
      --emulator "CMD ARGS"  the command that runs the build's programs (CMAKE_CROSSCOMPILING_EMULATOR
                             joined by spaces), put in front of every edgefused / edgefuse spawned
      --time-factor F        how much slower the programs run there: every wait for a port, a reply
                             or a result is F times longer (command()'s default wait included)
    Without them: ([], 1)."""
    global TIME_FACTOR
    prefix, factor, rest = [], 1.0, [argv[0]]
    i = 1
    while i < len(argv):
        if argv[i] in ("--emulator", "--time-factor") and i + 1 < len(argv):
            if argv[i] == "--emulator":
                prefix = shlex.split(argv[i + 1])
            else:
                factor = float(argv[i + 1])
            i += 2
        else:
            rest.append(argv[i])
            i += 1
    argv[:] = rest
    TIME_FACTOR = factor
    return prefix, factor


_started = []


def popen(args, **kwargs):
    """subprocess.Popen, the process killed at exit if it still runs (a failed check or an exception
    must not leave an edgefused streaming in the background)."""
    p = subprocess.Popen(args, **kwargs)
    _started.append(p)
    return p


@atexit.register
def _kill_started():
    for p in _started:
        if p.poll() is None:
            p.kill()
            p.wait()


def sigterm_and_wait(proc, timeout_s):
    """Stops a program with SIGTERM, as systemd would, and waits timeout_s (times TIME_FACTOR);
    kills it when it hangs, so the test goes on and reports the exit code (-9) as a failed check.
    Returns the exit code."""
    proc.send_signal(signal.SIGTERM)
    try:
        proc.wait(timeout=timeout_s * TIME_FACTOR)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
    return proc.returncode


def collect(proc, timeout_s):
    """(stdout, stderr) of a listener that should end by itself within timeout_s (times TIME_FACTOR);
    one still running then is killed and what it printed is returned (the caller's checks judge its
    exit code)."""
    try:
        return proc.communicate(timeout=timeout_s * TIME_FACTOR)
    except subprocess.TimeoutExpired:
        proc.kill()
        return proc.communicate()


def wait_started(proc, log, timeout_s):
    """Reads edgefused's start-up lines from its log file (`console: /dev/pts/N`, `tcp: HOST:PORT`,
    `robot: HOST:PORT`, ... then `ready`) until `ready`, the process ends or timeout_s passes (times
    TIME_FACTOR under an emulator). Returns {key: value}, with "ready": True once it was printed."""
    info = {}
    end = time.monotonic() + timeout_s * TIME_FACTOR
    while time.monotonic() < end and "ready" not in info and proc.poll() is None:
        time.sleep(0.05)
        log.seek(0)
        for line in log.read().splitlines():
            k, _, v = line.partition(": ")
            info[k] = v
            if line == "ready":
                info["ready"] = True
    return info


def check_started(proc, log, info, keys, what):
    """Checks that edgefused printed `ready` and the start-up lines keys (e.g. "robot", "console")
    name. When it did not, the check fails with its log printed (the reason is there) and the
    process is killed, so the caller can skip the run. Returns whether it started."""
    if "ready" in info and all(k in info for k in keys):
        return True
    log.seek(0)
    print(log.read())
    check(False, what)
    proc.kill()
    return False


def command(fd, line, timeout=10.0):
    """Sends a console line, returns the reply up to and including OK / ERR (or what came by timeout,
    in seconds on the host: TIME_FACTOR times that under an emulator)."""
    return console.command(fd, line, timeout * TIME_FACTOR)


class TextClient:
    """A raw line client of edgefused's robot text port on loopback: the tests check the replies'
    exact text, so unlike tools/robot/edgefuse_robot.py it neither parses nor raises on ERR."""

    def __init__(self, port, timeout_s):
        """Connects; timeout_s (times TIME_FACTOR under an emulator) bounds the connect and each recv."""
        self.s = socket.create_connection(("127.0.0.1", port), timeout=timeout_s * TIME_FACTOR)
        self.s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.buf = b""

    def line(self):
        """The next reply line, without its newline."""
        while b"\n" not in self.buf:
            chunk = self.s.recv(4096)
            if not chunk:
                raise EOFError("the text port closed the connection")
            self.buf += chunk
        line, _, self.buf = self.buf.partition(b"\n")
        return line.decode()

    def ask(self, text):
        """Sends one request line, returns its reply line."""
        self.s.sendall(text.encode() + b"\n")
        return self.line()


def vm_data_kib(pid):
    """The process's VmData in KiB (-1 if not found)."""
    with open("/proc/%d/status" % pid) as f:
        for line in f:
            if line.startswith("VmData:"):
                return int(line.split()[1])
    return -1


def wait_recording_mapped(con, frames_total, timeout_s, poll_s=0.3):
    """Polls the console's `status` until the replayed recording ended and each of its frames_total
    frames was integrated or dropped (the camera thread reports the end as soon as it published the
    last frame; the main loop integrates it a moment later), or timeout_s passed. Returns (frames,
    drops, the last status reply); drops is -1 when the status had none."""
    frames, drops, status = 0, -1, ""
    end = time.monotonic() + timeout_s
    while time.monotonic() < end and ("end of recording" not in status or frames + drops < frames_total):
        time.sleep(poll_s)
        status = command(con, "status")
        m = re.search(r"frames (\d+)", status)
        frames = int(m.group(1)) if m else frames
        m = re.search(r"drops (\d+)", status)
        drops = int(m.group(1)) if m else -1
    return frames, drops, status


# The checks of a test script: each printed as it is made; the failed ones kept for the exit code.
failures = []


def check(cond, what):
    """Records one check (printed `ok` / `FAIL`); returns cond."""
    print(("ok   " if cond else "FAIL ") + what, flush=True)
    if not cond:
        failures.append(what)
    return cond
