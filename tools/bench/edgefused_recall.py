#!/usr/bin/python3
"""Recall of edgefused on a replayed rig set (benchmark, prints figures; not a test).

usage: tools/bench/edgefused_recall.py BUILD_DIR RIG_SET WORKDIR [--set KEY=VALUE ...]
e.g.   tools/bench/edgefused_recall.py build/host ../shared/data/bin_rig_a /tmp/recall --set sensors.fuse=xtion,tof

Starts edgefused replaying the set at its ground-truth poses (tracking.poses=known; a --set
tracking.poses=tracked overrides it) with localize.still_period_s=1, `scan start` on its console pty,
takes the still-period result with `edgefuse listen --csv`, prints `status` (frames, drops and
every camera's acquisition counters), `edgefuse eval poses` against the set's objects.txt and
edgefused's localisation and extrinsics lines.
"""
import os, sys, time, subprocess, select, termios, re, signal
if len(sys.argv) < 4:
    sys.exit(__doc__)
B = os.path.abspath(sys.argv[1]) + "/"
EDGEFUSED = B + "src/firmware/edgefused"
EDGEFUSE = B + "tools/edgefuse"
RIG = os.path.abspath(sys.argv[2])
work = os.path.abspath(sys.argv[3]); extra = sys.argv[4:]
os.makedirs(work, exist_ok=True)
log = open(work + "/log.txt", "w+")
d = subprocess.Popen([EDGEFUSED, "--set", "link.tcp_port=0", "--set", "robot.text_port=0", "--set", "link.serial=", "--set", "console.echo=false",
                      "--set", "calib.dir=" + work + "/calib", "--set", "sensors.replay=" + RIG,
                      "--set", "tracking.poses=known", "--set", "localize.still_period_s=1"] + extra, stdout=log, stderr=subprocess.STDOUT, cwd=work)
info = {}
end = time.monotonic() + 120
while time.monotonic() < end and "ready" not in info and d.poll() is None:
    time.sleep(0.2); log.seek(0)
    for line in log.read().splitlines():
        k, _, v = line.partition(": "); info[k] = v
        if line == "ready": info["ready"] = True
if "ready" not in info:
    log.seek(0); print(log.read()); sys.exit(1)
fd = os.open(info["console"], os.O_RDWR | os.O_NOCTTY)
a = termios.tcgetattr(fd); a[0]=a[1]=a[3]=0; a[2]=termios.CS8|termios.CREAD|termios.CLOCAL; a[6][termios.VMIN]=1; a[6][termios.VTIME]=0
termios.tcsetattr(fd, termios.TCSANOW, a)
def cmd(line, timeout=30):
    os.write(fd, (line + "\r").encode()); got=b""; e=time.monotonic()+timeout
    while time.monotonic()<e:
        r,_,_=select.select([fd],[],[],0.1)
        if r:
            got+=os.read(fd,4096); ls=got.decode(errors="replace").split("\r\n")
            if any(l=="OK" or l.startswith("ERR ") for l in ls[:-1]): break
    return got.decode(errors="replace")
models = {int(m.group(1)): m.group(2) for m in re.finditer(r"^(\d+) (\S+)\r$", cmd("model list"), re.M)}
port = int(info["tcp"].rsplit(":", 1)[1])
listen = subprocess.Popen([EDGEFUSE, "listen", "--tcp", "127.0.0.1:%d" % port, "--csv", "--count", "1", "--timeout-s", "200"],
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
time.sleep(0.5)
cmd("scan start")
out, err = listen.communicate(timeout=260)
print(cmd("status"))
rows = [l.split(",") for l in out.strip().splitlines() if l[:1].isdigit()]
est = work + "/poses.txt"
with open(est, "w") as f:
    for k, r in enumerate(rows):
        f.write("%d %s %s %s\n" % (k + 1, " ".join(r[3:10]), r[10], models.get(int(r[2]), "unknown")))
ev = subprocess.run([EDGEFUSE, "eval", "poses", est, RIG + "/objects.txt"], capture_output=True, text=True)
print(ev.stdout)
d.send_signal(signal.SIGTERM); d.wait(timeout=30)
log.seek(0); print("\n".join(l for l in log.read().splitlines() if l.startswith(("localize", "extrinsics", "sensors"))))
