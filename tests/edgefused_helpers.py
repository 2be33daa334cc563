"""Helpers shared by the edgefused end-to-end tests (edgefused_e2e.py, edgefused_fusion_e2e.py):
the console pseudo-terminal in raw mode, one console command and its reply, the process's VmData."""
import os
import select
import termios
import time


def open_raw(dev):
    """Opens a console pty raw (8N1, no echo, no line editing)."""
    fd = os.open(dev, os.O_RDWR | os.O_NOCTTY)
    a = termios.tcgetattr(fd)
    a[0] = a[1] = a[3] = 0
    a[2] = termios.CS8 | termios.CREAD | termios.CLOCAL
    a[6][termios.VMIN] = 1
    a[6][termios.VTIME] = 0
    termios.tcsetattr(fd, termios.TCSANOW, a)
    return fd


def command(fd, line, timeout=10.0):
    """Sends a console line, returns the reply up to and including OK / ERR (or what came by timeout)."""
    os.write(fd, (line + "\r").encode())
    got = b""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        r, _, _ = select.select([fd], [], [], 0.1)
        if r:
            got += os.read(fd, 4096)
            lines = got.decode(errors="replace").split("\r\n")
            if any(l == "OK" or l.startswith("ERR ") for l in lines[:-1]):
                break
    return got.decode(errors="replace")


def vm_data_kib(pid):
    """The process's VmData in KiB (-1 if not found)."""
    with open("/proc/%d/status" % pid) as f:
        for line in f:
            if line.startswith("VmData:"):
                return int(line.split()[1])
    return -1
