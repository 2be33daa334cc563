"""edgefused's console pseudo-terminal from Python: opening it raw and one command with its reply.
The robot tools (robot_sim.py) and the tests (tests/edgefused_helpers.py) both talk to it, so the
line protocol (a line ends with CR, a reply ends with an `OK` or `ERR ...` line) is kept here once."""
import os
import select
import termios
import time


def open_raw(dev):
    """Opens a console pty raw (8N1, no echo, no line editing): replies arrive byte for byte."""
    fd = os.open(dev, os.O_RDWR | os.O_NOCTTY)
    a = termios.tcgetattr(fd)
    a[0] = a[1] = a[3] = 0
    a[2] = termios.CS8 | termios.CREAD | termios.CLOCAL
    a[6][termios.VMIN] = 1
    a[6][termios.VTIME] = 0
    termios.tcsetattr(fd, termios.TCSANOW, a)
    return fd


def command(fd, line, timeout_s):
    """Sends a console line, returns the reply up to and including OK / ERR (or what came within
    timeout_s: a reply cut short is returned as it is, for the caller to judge)."""
    os.write(fd, (line + "\r").encode())
    got = b""
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        r, _, _ = select.select([fd], [], [], 0.1)
        if r:
            got += os.read(fd, 4096)
            lines = got.decode(errors="replace").split("\r\n")
            if any(x == "OK" or x.startswith("ERR ") for x in lines[:-1]):
                break
    return got.decode(errors="replace")


def command_once(dev, line, timeout_s=5.0):
    """Opens the console, sends one line, closes it; returns the reply (see command)."""
    fd = open_raw(dev)
    try:
        return command(fd, line, timeout_s)
    finally:
        os.close(fd)
