#!/usr/bin/python3
"""Writes a station path for the sim rig (edgefused's sensors.sim_path, robot_sim.py --handeye): a
TUM-format file of rig (camera) poses in the sim world, each station as two keys (arrival and
departure: the rig holds still between them), the moves between them eased by edgefused.

The stations look at the bin's centre from --distance: the first straight down (as the sim rig's
circle), then one per azimuth, tilted about a horizontal axis through the bin's centre by the next
of --tilts and rolled about the viewing axis by the next of --rolls, so the rotations between
stations turn about several non-parallel axes (hand-eye calibration needs >= 2), and the last back
straight down. Adjacent stations are 20-40 deg apart: ICP from one station to the next would not
converge, the frames streamed during the moves (--move-s at 30 Hz: about 1 deg a frame) let it track.

usage: make_station_path.py [--out FILE] [--first-hold-s S] [--hold-s S] [--move-s S] [--distance M]
"""
import argparse
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from pose_math import axis_angle, compose, qnorm  # noqa: E402

CENTRE = (0.0, 0.0, 0.03)  # the bin's floor is z = 0, its rim 0.12 m
DOWN = (1.0, 0.0, 0.0, 0.0)  # x' = x, y' = -y, z' = -z: looking straight down (sim_rig_pose)


def station(distance, azimuth_deg, tilt_deg, roll_deg):
    """The camera at `distance` above CENTRE looking down, turned about the horizontal axis normal
    to the azimuth through CENTRE by tilt, then rolled about its own viewing axis."""
    looking_down = ((CENTRE[0], CENTRE[1], CENTRE[2] + distance), qnorm(DOWN))
    rolled = compose(looking_down, ((0.0, 0.0, 0.0), axis_angle((0.0, 0.0, 1.0), math.radians(roll_deg))))
    a = math.radians(azimuth_deg)
    axis = (-math.sin(a), math.cos(a), 0.0)  # tilting about it moves the camera towards the azimuth
    about_centre = compose(((CENTRE[0], CENTRE[1], CENTRE[2]), axis_angle(axis, math.radians(tilt_deg))),
                           ((-CENTRE[0], -CENTRE[1], -CENTRE[2]), (0.0, 0.0, 0.0, 1.0)))
    return compose(about_centre, rolled)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="-")
    ap.add_argument("--first-hold-s", type=float, default=2.5, help="hold at the first station (start-up, CAPTURE) [2.5]")
    ap.add_argument("--hold-s", type=float, default=1.2, help="hold at every other station [1.2]")
    ap.add_argument("--move-s", type=float, default=2.5, help="move between stations [2.5]")
    ap.add_argument("--distance", type=float, default=0.67, help="camera to the bin's centre, m [0.67]")
    ap.add_argument("--azimuths", default="0,51,103,154,206,257,309", help="degrees, one station each")
    ap.add_argument("--tilts", default="20,15,25,18,22,16,24", help="degrees, one per azimuth")
    ap.add_argument("--rolls", default="12,-12,15,-10,10,-14,8", help="degrees, one per azimuth")
    args = ap.parse_args()
    az = [float(x) for x in args.azimuths.split(",")]
    tilts = [float(x) for x in args.tilts.split(",")]
    rolls = [float(x) for x in args.rolls.split(",")]
    poses = [station(args.distance, 0, 0, 0)] + [station(args.distance, a, t, r) for a, t, r in zip(az, tilts, rolls)]
    poses.append(station(args.distance, 0, 0, -10))
    lines = ["# sim rig station path (tools/robot/make_station_path.py %s)" % " ".join(sys.argv[1:]),
             "# stamp tx ty tz qx qy qz qw: rig pose in the sim world; two keys per station (the rig holds between them)"]
    t = 0.0
    for i, (p, q) in enumerate(poses):
        hold = args.first_hold_s if i == 0 else args.hold_s
        for stamp in (t, t + hold):
            lines.append("%.3f %.6f %.6f %.6f %.7f %.7f %.7f %.7f" % ((stamp,) + tuple(p) + tuple(q)))
        t += hold + args.move_s
    text = "\n".join(lines) + "\n"
    if args.out == "-":
        sys.stdout.write(text)
    else:
        with open(args.out, "w") as f:
            f.write(text)


if __name__ == "__main__":
    main()
