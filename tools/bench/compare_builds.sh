#!/usr/bin/env bash
# tools/bench/compare_builds.sh OLD_TOOLS_DIR NEW_TOOLS_DIR [OUT_DIR]
# Runs the same commands with two builds of `edgefuse` (e.g. main's and a branch's build/host/tools)
# and compares what they produce: the pose lists of `localize` on bin_rig_a (xtion; xtion,tof,laser;
# --track), the `fuse` clouds (bin_rig_a xtion and xtion,tof,laser; TUM fr1/xyz), and the `track`
# trajectory of TUM fr1/xyz with its ATE. Each result is `same` (cmp) or `DIFFERS`; the times of
# both builds are printed side by side (fuse integrate_ms, track loop_ms). Exit 0 when all are the same.
set -uo pipefail
old=${1:?usage: compare_builds.sh OLD_TOOLS_DIR NEW_TOOLS_DIR [OUT_DIR]}
new=${2:?usage: compare_builds.sh OLD_TOOLS_DIR NEW_TOOLS_DIR [OUT_DIR]}
out=${3:-/tmp/edgefuse-compare}
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
data=${EDGEFUSE_SHARED_DATA:-$repo/../shared/data}
rig=$data/bin_rig_a
tum=$data/tum_fr1_xyz_37
mkdir -p "$out/old" "$out/new"
differs=0
models=()
for m in box bracket can cylinder; do models+=(--model "$rig/models/$m.ply"); done

run() {  # run NAME ARGS... (with {OUT} replaced by the build's output folder)
  local name=$1; shift
  for b in old new; do
    local exe=$old/edgefuse; [[ $b == new ]] && exe=$new/edgefuse
    local args=("${@//\{OUT\}/$out/$b}")
    "$exe" "${args[@]}" >"$out/$b/$name.log" 2>&1 || echo "  $b: $name exited $?"
  done
}
same() {  # same NAME FILE
  if cmp -s "$out/old/$2" "$out/new/$2"; then echo "same     $1 ($2)"; else echo "DIFFERS  $1 ($2)"; differs=1; fi
}
figure() {  # figure NAME KEY: the key's value in both logs
  printf '         %-28s %-16s old %-10s new %s\n' "$1" "$2" \
    "$(grep -o "$2=[0-9.]*" "$out/old/$1.log" | tail -1 | cut -d= -f2)" \
    "$(grep -o "$2=[0-9.]*" "$out/new/$1.log" | tail -1 | cut -d= -f2)"
}

run localize_xtion localize "$rig" --sensor xtion "${models[@]}" --out "{OUT}/poses_xtion.txt"
same "localize --sensor xtion" poses_xtion.txt
run localize_rig localize "$rig" --sensors xtion,tof,laser "${models[@]}" --out "{OUT}/poses_rig.txt"
same "localize --sensors xtion,tof,laser" poses_rig.txt
run localize_track localize "$rig" --sensor xtion --track "${models[@]}" --out "{OUT}/poses_track.txt"
same "localize --track" poses_track.txt
run fuse_xtion fuse "$rig" --sensor xtion --out "{OUT}/fuse_xtion.ply"
same "fuse --sensor xtion" fuse_xtion.ply
figure fuse_xtion integrate_ms
run fuse_rig fuse "$rig" --sensors xtion,tof,laser --out "{OUT}/fuse_rig.ply"
same "fuse --sensors xtion,tof,laser" fuse_rig.ply
run fuse_tum fuse "$tum" --voxel 0.01 --volume 256 --out "{OUT}/fuse_tum.ply"
same "fuse tum_fr1_xyz_37" fuse_tum.ply
figure fuse_tum integrate_ms
run track_tum track "$tum" --voxel 0.01 --out "{OUT}/track_tum.txt"
same "track tum_fr1_xyz_37" track_tum.txt
figure track_tum loop_ms
for b in old new; do
  exe=$old/edgefuse; [[ $b == new ]] && exe=$new/edgefuse
  "$exe" eval ate "$out/$b/track_tum.txt" "$tum" >"$out/$b/ate.log" 2>&1
done
figure ate ate_rmse_m
run track_rig track "$rig" --sensor xtion --out "{OUT}/track_rig.txt"
same "track bin_rig_a xtion" track_rig.txt
figure track_rig loop_ms
exit $differs
