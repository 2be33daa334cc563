#!/usr/bin/python3
"""Paired timing of two edgefuse_tsdf_bench binaries (A = before, B = after a raycast change).

The shared VM's speed drifts by +-10 % within minutes, far more than most single changes to the
raycast are worth; unpaired runs minutes apart cannot show them. This script alternates the two
binaries (A B, B A, A B, ...) on the same data set, reads each run's thread CPU per raycast on
the final volume, and prints every pair, both medians, the median of the per-pair ratios B/A and in
how many pairs B was faster. Two binaries of the same code gave 1.021 (B faster in 2 of 10
pairs) in alternating order and 0.967 (7 of 10) when A always ran first: read a change as real
only when the ratio is clearly outside that (below ~0.96 with most pairs agreeing). Instruction
counts (callgrind) are the repeatable complement, but a change of -11 % instructions has been
measured with no time effect (docs/BENCHMARKS.md).

  /usr/bin/python3 tools/bench/ab_raycast.py BIN_A BIN_B [--pairs 10] [--reps 6]
      [--data ../shared/data/bin_rig_a] [--sensor xtion] [-- extra bench arguments]

Both binaries get --no-colour-map (the tracking loop's raycast) unless --colour is given.
"""

import argparse
import os
import re
import statistics
import subprocess
import sys

FINAL = re.compile(r"([0-9.]+) ms on the final volume \((\d+) casts; of which prepare ([0-9.]+) ms\)")


def run(binary, args):
    """One bench run: (final-volume ms per raycast, prepare ms), or exits naming the binary."""
    proc = subprocess.run([binary] + args, capture_output=True, text=True)
    m = FINAL.search(proc.stdout)
    if proc.returncode != 0 or m is None:
        sys.exit(f"ab_raycast: {binary} failed (exit {proc.returncode}): {proc.stderr.strip()[:300]}")
    return float(m.group(1)), float(m.group(3))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("bin_a")
    ap.add_argument("bin_b")
    ap.add_argument("--pairs", type=int, default=10)
    ap.add_argument("--reps", type=int, default=6)
    ap.add_argument("--data", default="../shared/data/bin_rig_a")
    ap.add_argument("--sensor", default="xtion")
    ap.add_argument("--colour", action="store_true", help="raycast the colour map too")
    ap.add_argument("extra", nargs="*", help="more bench arguments (after --)")
    a = ap.parse_args()
    for b in (a.bin_a, a.bin_b):
        if not os.access(b, os.X_OK):
            sys.exit(f"ab_raycast: {b} is not an executable")
    if not os.path.isdir(a.data):
        sys.exit(f"ab_raycast: data set {a.data} not found (see ../shared/data/README)")
    args = [a.data, "--sensor", a.sensor, "--reps", str(a.reps)] + ([] if a.colour else ["--no-colour-map"]) + a.extra
    load0 = os.getloadavg()[0]
    ra, rb = [], []
    for i in range(a.pairs):
        # A B, then B A: the second run of a pair was ~3 % faster in an A/A test (same binary
        # code), so the order alternates to cancel that bias.
        if i % 2 == 0:
            ta, pa = run(a.bin_a, args)
            tb, pb = run(a.bin_b, args)
        else:
            tb, pb = run(a.bin_b, args)
            ta, pa = run(a.bin_a, args)
        ra.append(ta)
        rb.append(tb)
        print(f"pair {i + 1:2d}: A {ta:6.2f} ms (prepare {pa:.2f})   B {tb:6.2f} ms (prepare {pb:.2f})   B/A {tb / ta:.3f}",
              flush=True)
    ratios = [b / x for x, b in zip(ra, rb)]
    faster = sum(1 for r in ratios if r < 1.0)
    print(f"median A {statistics.median(ra):.2f} ms, B {statistics.median(rb):.2f} ms; "
          f"median B/A {statistics.median(ratios):.3f} (range {min(ratios):.3f}-{max(ratios):.3f}); "
          f"B faster in {faster} of {a.pairs} pairs; load average {load0:.2f} -> {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
