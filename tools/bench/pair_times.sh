#!/usr/bin/env bash
# tools/bench/pair_times.sh OLD_EDGEFUSE NEW_EDGEFUSE [PAIRS]
# Paired timing of two builds of `edgefuse` in alternating order (O N, N O, ...): integration per
# frame (`fuse tum_fr1_xyz_37 --voxel 0.01 --volume 256 --threads 1`, integrate_ms) and the tracking
# loop per frame (`track bin_rig_a --sensor xtion --threads 1`, process CPU loop_ms). Prints each run
# and the median new/old ratios. The VM's speed drifts within minutes, so only paired ratios count.
set -euo pipefail
old=${1:?usage: pair_times.sh OLD_EDGEFUSE NEW_EDGEFUSE [PAIRS]}
new=${2:?usage: pair_times.sh OLD_EDGEFUSE NEW_EDGEFUSE [PAIRS]}
pairs=${3:-6}
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
data=${EDGEFUSE_SHARED_DATA:-$repo/../shared/data}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for ((i = 1; i <= pairs; ++i)); do
  order="old new"; ((i % 2)) || order="new old"
  for b in $order; do
    exe=$old; [[ $b == new ]] && exe=$new
    fi=$("$exe" fuse "$data/tum_fr1_xyz_37" --voxel 0.01 --volume 256 --threads 1 --out "$tmp/f.ply" |
         grep -o "integrate_ms=[0-9.]*" | cut -d= -f2)
    tl=$("$exe" track "$data/bin_rig_a" --sensor xtion --threads 1 --out "$tmp/t.txt" | grep "^cpu" |
         grep -o "loop_ms=[0-9.]*" | cut -d= -f2)
    echo "$i $b $fi $tl"
  done
done | tee "$tmp/runs" | awk '{print "pair " $1 " " $2 ": integrate_ms " $3 ", loop_cpu_ms " $4}'
/usr/bin/python3 - "$tmp/runs" <<'PY'
import statistics, sys
d = {}
for line in open(sys.argv[1]):
    i, b, fi, tl = line.split()
    d.setdefault(i, {})[b] = (float(fi), float(tl))
for k, name in ((0, "integrate_ms"), (1, "loop_cpu_ms")):
    r = [p["new"][k] / p["old"][k] for p in d.values()]
    print("%s: median old %.2f new %.2f; median new/old %.3f (%.3f-%.3f), new faster in %d of %d" % (
        name, statistics.median(p["old"][k] for p in d.values()), statistics.median(p["new"][k] for p in d.values()),
        statistics.median(r), min(r), max(r), sum(x < 1 for x in r), len(r)))
PY
