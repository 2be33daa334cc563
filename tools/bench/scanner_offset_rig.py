#!/usr/bin/python3
"""Writes a copy of a rig set whose line scanner's recorded poses carry a known error, to measure
what `edgefuse fuse --sensors ...,laser --register-laser` removes.

Every recorded pose T_world_sensor of the scanner becomes T * offset (a translation in the sensor
frame); everything else of the set is linked, not copied. On a simulated rig the recorded poses are
exact, so the error put on them is the error the registration has to find.

  /usr/bin/python3 tools/bench/scanner_offset_rig.py RIGSET OUT [--sensor laser]
        [--offset 0.002,-0.0015,0.001]
"""
import argparse
import os
import shutil

DEFAULT_OFFSET = "0.002,-0.0015,0.001"  # metres, sensor frame: 2.7 mm


def rotate(q, v):
    """v rotated by the unit quaternion q = (qx, qy, qz, qw)."""
    x, y, z, w = q
    n = (x * x + y * y + z * z + w * w) ** 0.5
    x, y, z, w = x / n, y / n, z / n, w / n
    # v + 2 w (u x v) + 2 u x (u x v), u = (x, y, z)
    cx, cy, cz = y * v[2] - z * v[1], z * v[0] - x * v[2], x * v[1] - y * v[0]
    ccx, ccy, ccz = y * cz - z * cy, z * cx - x * cz, x * cy - y * cx
    return (v[0] + 2 * (w * cx + ccx), v[1] + 2 * (w * cy + ccy), v[2] + 2 * (w * cz + ccz))


def write_offset_rig(rig, out, sensor="laser", offset=DEFAULT_OFFSET):
    """Creates OUT (replacing it) as RIGSET with `sensor`'s groundtruth.txt poses times the offset."""
    o = [float(x) for x in offset.split(",")]
    if len(o) != 3:
        raise ValueError("--offset: expected tx,ty,tz (metres), got '%s'" % offset)
    rig = os.path.abspath(rig)
    if os.path.lexists(out):
        shutil.rmtree(out)
    os.makedirs(os.path.join(out, sensor))
    for name in os.listdir(rig):
        if name != sensor:
            os.symlink(os.path.join(rig, name), os.path.join(out, name))
    src = os.path.join(rig, sensor)
    for name in os.listdir(src):
        if name != "groundtruth.txt":
            os.symlink(os.path.join(src, name), os.path.join(out, sensor, name))
    with open(os.path.join(src, "groundtruth.txt")) as f, open(os.path.join(out, sensor, "groundtruth.txt"), "w") as g:
        for line in f:
            v = line.split()
            if line.startswith("#") or len(v) < 8:
                g.write(line)
                continue
            q = [float(x) for x in v[4:8]]
            d = rotate(q, o)
            t = [float(v[1 + i]) + d[i] for i in range(3)]
            g.write("%s %.9f %.9f %.9f %s\n" % (v[0], t[0], t[1], t[2], " ".join(v[4:8])))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("rig")
    ap.add_argument("out")
    ap.add_argument("--sensor", default="laser")
    ap.add_argument("--offset", default=DEFAULT_OFFSET, help="tx,ty,tz in metres, sensor frame")
    a = ap.parse_args()
    write_offset_rig(a.rig, a.out, a.sensor, a.offset)
    print("%s: %s's poses offset by %s m (sensor frame)" % (a.out, a.sensor, a.offset))


if __name__ == "__main__":
    main()
