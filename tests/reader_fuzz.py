#!/usr/bin/python3
"""Mutation test of the file readers through the `edgefuse` program (corrupt-input rule of DEVELOPERS.md).

  reader_fuzz.py EDGEFUSE DATA_DIR WORK_DIR [--count N] [--seed S] [--edgefused BIN --board-dir DIR] [--verbose]

Takes valid inputs of every file format the program reads, corrupts them the ways files get
corrupted (bit flips, truncation anywhere and inside the header, zeroed and repeated blocks, header
numbers replaced by 0, -1, huge values or 'nan'), runs the command that reads each one and demands:
  - no crash and no sanitizer report (the host-asan preset runs this test too),
  - no hang (60 s per run),
  - exit 0, or a failure whose last stderr line names a file of the input (the corrupted one, or
    for a consistency check such as "image is 640x480 but the intrinsics say 640x3", its partner).
The unit tests hold the hand-made corrupt cases of each reader; this covers the combinations no
one wrote down. Seeded: a failure prints the mutation and keeps the input under WORK_DIR/failed/.

Seeds (built from DATA_DIR, never copied into the repository): a binary_compressed PCD
(mosd_learn/learn0.pcd), a binary PLY mesh (bin_rig_a/models/can.ply) as a cloud and as a
--model, a 16-bit depth PNG and camera.toml (lmo_can_frame), a TUM sequence's depth.txt and
groundtruth.txt (tum_fr1_xyz_37), the rig set's rig.toml, extrinsics.txt and laser
profiles.txt (bin_rig_a, fused with --sensors xtion,laser), and binary PCD, ascii PCD and ascii PLY written by this script
from `edgefuse fuse lmo_can_frame`'s cloud. With --edgefused, also the runtime configuration
(DIR/host-sim/edgefused.toml, read by `edgefused --check --config FILE`). Skips (exit 0 with a message) when DATA_DIR lacks them.
"""

import argparse
import os
import random
import re
import shutil
import struct
import subprocess
import sys

SANITIZER_MARKS = ("ERROR: AddressSanitizer", "runtime error:", "ERROR: LeakSanitizer", "AddressSanitizer:DEADLYSIGNAL")
HEADER_ENDS = (b"end_header\n", b"DATA ascii\n", b"DATA binary\n", b"DATA binary_compressed\n")
HEADER_VALUES = ("0", "-1", "3", "65536", "2147483648", "4294967295", "99999999999", "1e9", "nan")


def header_length(data, kind):
    """Bytes of the part of a file whose damage the readers must name precisely."""
    if kind in ("pcd", "ply"):
        for end in HEADER_ENDS:
            i = data.find(end)
            if i >= 0:
                return i + len(end)
    if kind == "png":
        return min(len(data), 64)  # signature, IHDR and the start of the first chunk
    return len(data)  # text files: all of it is header


def mutate(rng, data, header_len):
    """One corruption of `data`: (bytes, description)."""
    b = bytearray(data)
    kind = rng.choice(("flip", "flip_header", "truncate", "truncate_header", "zero_block", "repeat_block", "header_number"))
    if kind == "flip":
        spots = sorted(rng.randrange(len(b)) for _ in range(rng.randint(1, 16)))
        for i in spots:
            b[i] ^= 1 << rng.randrange(8)
        return bytes(b), "bits flipped at %s" % spots[:4]
    if kind == "flip_header":
        spots = sorted(rng.randrange(max(1, header_len)) for _ in range(rng.randint(1, 3)))
        for i in spots:
            b[i] = rng.randrange(256)
        return bytes(b), "header bytes replaced at %s" % spots
    if kind == "truncate":
        n = rng.randrange(len(b))
        return bytes(b[:n]), "truncated to %d of %d bytes" % (n, len(b))
    if kind == "truncate_header":
        n = rng.randrange(min(len(b), header_len + 8))
        return bytes(b[:n]), "truncated in the header to %d bytes" % n
    i = rng.randrange(len(b))
    j = min(len(b), i + rng.randint(1, 4096))
    if kind == "zero_block":
        b[i:j] = bytes(j - i)
        return bytes(b), "bytes %d..%d zeroed" % (i, j)
    if kind == "repeat_block":
        return bytes(b[:j] + b[i:j] + b[j:]), "bytes %d..%d repeated" % (i, j)
    text = bytes(b[:header_len]).decode("latin1")
    numbers = list(re.finditer(r"\d+", text))
    if not numbers:
        return bytes(b[:-1]), "last byte dropped (no header number)"
    m = rng.choice(numbers)
    value = rng.choice(HEADER_VALUES)
    text = text[: m.start()] + value + text[m.end():]
    return text.encode("latin1") + bytes(b[header_len:]), "header number at byte %d set to %s" % (m.start(), value)


def read_cloud_fields(pcd_path):
    """Points of a binary PCD written by edgefuse (x y z normal_x normal_y normal_z rgba, 4 bytes each)."""
    data = open(pcd_path, "rb").read()
    end = data.index(b"DATA binary\n") + len(b"DATA binary\n")
    header = data[:end].decode("ascii")
    if "FIELDS x y z normal_x normal_y normal_z rgba" not in header:
        raise RuntimeError("%s: unexpected fields" % pcd_path)
    n = int(re.search(r"POINTS (\d+)", header).group(1))
    rec = struct.Struct("<6fI")
    return [rec.unpack_from(data, end + k * rec.size) for k in range(n)]


def write_derived_seeds(points, out_dir):
    """A binary PCD, an ascii PCD and an ascii PLY of `points` (every 10th point, to keep runs short)."""
    pts = points[::10]
    head = ("VERSION 0.7\nFIELDS x y z normal_x normal_y normal_z rgba\nSIZE 4 4 4 4 4 4 4\nTYPE F F F F F F U\n"
            "COUNT 1 1 1 1 1 1 1\nWIDTH %d\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS %d\n" % (len(pts), len(pts)))
    rec = struct.Struct("<6fI")
    paths = {}
    paths["binary.pcd"] = os.path.join(out_dir, "binary.pcd")
    with open(paths["binary.pcd"], "wb") as f:
        f.write((head + "DATA binary\n").encode("ascii"))
        for p in pts:
            f.write(rec.pack(*p))
    paths["ascii.pcd"] = os.path.join(out_dir, "ascii.pcd")
    with open(paths["ascii.pcd"], "w") as f:
        f.write(head + "DATA ascii\n")
        for p in pts:
            f.write("%.6g %.6g %.6g %.5f %.5f %.5f %d\n" % p)
    paths["ascii.ply"] = os.path.join(out_dir, "ascii.ply")
    with open(paths["ascii.ply"], "w") as f:
        f.write("ply\nformat ascii 1.0\nelement vertex %d\nproperty float x\nproperty float y\nproperty float z\n"
                "property float nx\nproperty float ny\nproperty float nz\nproperty uchar red\nproperty uchar green\n"
                "property uchar blue\nend_header\n" % len(pts))
        for p in pts:
            c = p[6]
            f.write("%.6g %.6g %.6g %.5f %.5f %.5f %d %d %d\n" % (p[:6] + ((c >> 16) & 255, (c >> 8) & 255, c & 255)))
    return paths


def link_tree(src, dst):
    """dst mirrors src: a folder per folder, a symbolic link per file (the corrupted file replaces its link)."""
    for root, dirs, files in os.walk(src):
        here = os.path.join(dst, os.path.relpath(root, src))
        os.makedirs(here, exist_ok=True)
        for f in files:
            os.symlink(os.path.join(root, f), os.path.join(here, f))


class Target:
    """One seed file, where its corrupted copy goes and the command that reads it."""

    def __init__(self, name, seed, kind, place):
        self.name, self.seed, self.kind, self.place = name, seed, kind, place


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("edgefuse")
    ap.add_argument("data")
    ap.add_argument("work")
    ap.add_argument("--count", type=int, default=20, help="corrupted copies per seed (default 20)")
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--timeout", type=float, default=60.0, help="seconds per run")
    ap.add_argument("--verbose", action="store_true", help="print every corruption and its outcome")
    ap.add_argument("--edgefused", help="the edgefused binary: its --check reads a corrupted edgefused.toml")
    ap.add_argument("--board-dir", help="the repository's board/ folder (with --edgefused)")
    a = ap.parse_args()

    need = ["mosd_learn/learn0.pcd", "bin_rig_a/models/can.ply", "lmo_can_frame/depth.png",
            "lmo_can_frame/camera.toml", "tum_fr1_xyz_37/depth.txt", "tum_fr1_xyz_37/groundtruth.txt",
            "bin_rig_a/rig.toml", "bin_rig_a/extrinsics.txt", "bin_rig_a/laser/profiles.txt"]
    missing = [p for p in need if not os.path.isfile(os.path.join(a.data, p))]
    if missing:
        print("SKIP: %s lacks %s (the shared test data)" % (a.data, ", ".join(missing)))
        return 0
    shutil.rmtree(a.work, ignore_errors=True)
    seeds_dir = os.path.join(a.work, "seeds")
    os.makedirs(seeds_dir)

    def run(cmd):
        """(exit code, stderr, stdout) of one command, or None when it hangs."""
        try:
            p = subprocess.run(cmd, capture_output=True, timeout=a.timeout)
        except subprocess.TimeoutExpired:
            return None
        return p.returncode, p.stderr.decode("utf-8", "replace"), p.stdout.decode("utf-8", "replace")

    # The derived seeds come from the program's own writer (a cloud of the LINEMOD frame).
    fused = os.path.join(seeds_dir, "lmo.pcd")
    r = run([a.edgefuse, "fuse", os.path.join(a.data, "lmo_can_frame"), "--volume", "128", "--out", fused])
    if r is None or r[0] != 0:
        print("FAIL: could not write the derived seeds: %s" % ("timeout" if r is None else r[1].strip()))
        return 1
    derived = write_derived_seeds(read_cloud_fields(fused), seeds_dir)

    D = os.path.abspath(a.data)  # absolute: the TUM case links its image folders
    targets = [
        Target("binary_compressed PCD", os.path.join(D, "mosd_learn/learn0.pcd"), "pcd", "cloud"),
        Target("binary PCD", derived["binary.pcd"], "pcd", "cloud"),
        Target("ascii PCD", derived["ascii.pcd"], "pcd", "cloud"),
        Target("binary PLY cloud", os.path.join(D, "bin_rig_a/models/can.ply"), "ply", "cloud"),
        Target("ascii PLY cloud", derived["ascii.ply"], "ply", "cloud"),
        Target("PLY model (mesh)", os.path.join(D, "bin_rig_a/models/can.ply"), "ply", "model"),
        Target("16-bit depth PNG", os.path.join(D, "lmo_can_frame/depth.png"), "png", "frame"),
        Target("camera.toml", os.path.join(D, "lmo_can_frame/camera.toml"), "text", "frame"),
        Target("TUM depth.txt", os.path.join(D, "tum_fr1_xyz_37/depth.txt"), "text", "tum"),
        Target("TUM groundtruth.txt", os.path.join(D, "tum_fr1_xyz_37/groundtruth.txt"), "text", "tum"),
        Target("rig.toml", os.path.join(D, "bin_rig_a/rig.toml"), "text", "rig"),
        Target("rig extrinsics.txt", os.path.join(D, "bin_rig_a/extrinsics.txt"), "text", "rig"),
        Target("laser profiles.txt", os.path.join(D, "bin_rig_a/laser/profiles.txt"), "text", "rig"),
    ]
    if a.edgefused:
        targets.append(Target("edgefused.toml", os.path.join(os.path.abspath(a.board_dir), "host-sim/edgefused.toml"),
                              "text", "config"))
    rng = random.Random(a.seed)
    scene = derived["binary.pcd"]  # the scene for --model runs
    failures = 0
    print("%-22s %6s %8s %8s" % ("seed", "runs", "accepted", "refused"))
    for t in targets:
        data = open(t.seed, "rb").read()
        hlen = header_length(data, t.kind)
        accepted = refused = 0
        # Copy -1 is the seed unchanged: it must be accepted, or the corrupted copies prove nothing.
        for k in range(-1, a.count):
            mdata, how = (data, "unchanged") if k < 0 else mutate(rng, data, hlen)
            case_dir = os.path.join(a.work, "case")
            shutil.rmtree(case_dir, ignore_errors=True)
            os.makedirs(case_dir)
            out = os.path.join(a.work, "out")
            if t.place in ("cloud", "model"):
                path = os.path.join(case_dir, "input" + os.path.splitext(t.seed)[1])
                if t.place == "cloud":
                    args = [a.edgefuse, "localize", path, "--segments", "--max", "1", "--out", out + ".pcd"]
                else:
                    args = [a.edgefuse, "localize", scene, "--model", path, "--max", "1", "--out", out + ".txt"]
            elif t.place == "frame":
                for f in ("depth.png", "camera.toml"):
                    shutil.copyfile(os.path.join(D, "lmo_can_frame", f), os.path.join(case_dir, f))
                path = os.path.join(case_dir, os.path.basename(t.seed))
                args = [a.edgefuse, "fuse", case_dir, "--volume", "64", "--out", out + ".ply"]
            elif t.place == "config":
                path = os.path.join(case_dir, "edgefused.toml")
                args = [a.edgefused, "--board", "host-sim", "--check", "--config", path]
            elif t.place == "tum":  # a TUM folder: its lists point at the shared data's images
                link_tree(os.path.join(D, "tum_fr1_xyz_37"), case_dir)
                path = os.path.join(case_dir, os.path.basename(t.seed))
                args = [a.edgefuse, "fuse", case_dir, "--frames", "2", "--volume", "64", "--out", out + ".ply"]
            else:  # the rig set, fused with its line scanner (rig.toml, extrinsics, laser profiles)
                link_tree(os.path.join(D, "bin_rig_a"), case_dir)
                path = os.path.join(case_dir, os.path.relpath(t.seed, os.path.join(D, "bin_rig_a")))
                args = [a.edgefuse, "fuse", case_dir, "--sensors", "xtion,laser", "--frames", "2", "--volume", "64",
                        "--out", out + ".ply"]
            if os.path.islink(path):
                os.unlink(path)
            with open(path, "wb") as f:
                f.write(mdata)
            r = run(args)
            problem = None
            if r is None:
                problem = "no answer within %.0f s" % a.timeout
            else:
                rc, err, out_text = r
                if rc < 0 or any(m in err for m in SANITIZER_MARKS):
                    problem = "crashed (exit %d): %s" % (rc, err.strip()[-2000:])
                elif k < 0:
                    if rc != 0 or (t.place == "config" and "configuration OK" not in out_text):
                        problem = "the unchanged seed is refused (exit %d): %s" % (rc, err.strip()[-500:])
                elif rc == 0:
                    accepted += 1
                else:
                    # split("\n"), not splitlines(): that also splits at \x1c-\x1e, which a message may quote.
                    last = err.strip().split("\n")[-1] if err.strip() else ""
                    if case_dir not in last and os.path.basename(path) not in last:
                        problem = "exit %d without naming the input: %r" % (rc, last)
                    else:
                        refused += 1
            if a.verbose:
                print("  %s: %s -> %s" % (t.name, how, problem or ("accepted" if r[0] == 0 else r[1].strip().split("\n")[-1])))
            if problem:
                failures += 1
                keep = os.path.join(a.work, "failed", "%s_%d" % (re.sub(r"\W+", "_", t.name), k))
                os.makedirs(os.path.dirname(keep), exist_ok=True)
                shutil.copytree(case_dir, keep, symlinks=True)
                print("FAIL: %s, copy %d (%s): %s\n      input kept in %s\n      command: %s" %
                      (t.name, k, how, problem, keep, " ".join(args)))
        print("%-22s %6d %8d %8d" % (t.name, a.count, accepted, refused))
    if failures:
        print("FAIL: %d corrupted inputs were not handled (seed %d)" % (failures, a.seed))
        return 1
    print("all %d corrupted inputs handled: accepted or refused with the file named (seed %d)" %
          (a.count * len(targets), a.seed))
    return 0


if __name__ == "__main__":
    sys.exit(main())
