# ctest script on tum_fr1_xyz_37 (a desk-sized room seen from 0.9-3.6 m): the board's default space
# (host-sim: 256^3 x 2 mm = 0.51 m) is sized to what the first frame sees: over the board's whole
# brick index (512^3), at the finest voxel that holds it: 1 cm (5.12 m), where the dense 256^3
# cube needed 2 cm.
#  - `track` without --voxel prints the sizing line and tracks the 5 frames (none lost).
#  - `track --voxel 0.002` keeps the user's space and prints the warning with the --voxel to pass.
#  - `fuse` without --voxel sizes the same way.
#  - A run that tracks badly ends with advice, not just counts: absent from the sized runs; present
#    on 7-Scenes (when found) kept at --voxel 0.002, where the frames after the first come out degraded.
# Variables: EDGEFUSE (CLI), DATA (shared data folder), WORK (scratch folder).
include(${CMAKE_CURRENT_LIST_DIR}/cli_script_helpers.cmake)
set(TUM ${DATA}/tum_fr1_xyz_37)
if(NOT EXISTS ${TUM}/groundtruth.txt)
  message(STATUS "skipped: ${TUM} not found (set EDGEFUSE_SHARED_DATA)")
  return()
endif()
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})

run_ok(sized ${EDGEFUSE} track ${TUM} --frames 5 --out ${WORK}/sized.txt)
if(NOT sized MATCHES "track: the first frame spans [0-9.]+-[0-9.]+ m; the board's [0-9]+\\^3 x [0-9.]+ mm space \\([0-9.]+ m\\) holds [0-9]+ % of it: using [0-9]+\\^3 x [0-9.]+ c?m+ voxels \\([0-9.]+ m\\), pass --voxel to choose")
  message(FATAL_ERROR "track with the board's defaults must size the space and say so:\n${sized}")
endif()
if(NOT sized MATCHES "using 512\\^3 x 1 cm voxels")
  message(FATAL_ERROR "host-sim's 512^3 index must hold this room at 1 cm:\n${sized}")
endif()
match_value("${sized}" "lost=([0-9]+)" "lost=" lost)
if(NOT lost EQUAL 0 OR sized MATCHES "were not tracked well")
  message(FATAL_ERROR "the sized space must track every frame:\n${sized}")
endif()

run_ok(kept ${EDGEFUSE} track ${TUM} --frames 5 --voxel 0.002 --out ${WORK}/kept.txt)
if(NOT kept MATCHES "track: warning: the first frame spans [^\n]* holds [0-9]+ % of it; [^\n]*pass --voxel [0-9.]+ \\([0-9.]+ m\\) to hold 90 %")
  message(FATAL_ERROR "track --voxel 0.002 must warn and name the --voxel to pass:\n${kept}")
endif()
if(NOT kept MATCHES "volume: 256\\^3 voxels of 0\\.0020 m")
  message(FATAL_ERROR "an explicit --voxel must be kept:\n${kept}")
endif()

run_ok(fused ${EDGEFUSE} fuse ${TUM} --frames 1 --out ${WORK}/fused.ply)
if(NOT fused MATCHES "fuse: the first frame spans [^\n]*: using [0-9]+\\^3 x [0-9.]+ c?m+ voxels")
  message(FATAL_ERROR "fuse with the board's defaults must size the space and say so:\n${fused}")
endif()
set(KITCHEN ${DATA}/7scenes_redkitchen_300)
if(EXISTS ${KITCHEN}/camera.toml)
  run_ok(bad ${EDGEFUSE} track ${KITCHEN} --frames 4 --voxel 0.002 --out ${WORK}/bad.txt)
  if(NOT bad MATCHES "track: [0-9]+ of 3 frames were not tracked well \\(lost [0-9]+, degraded [0-9]+\\):[^\n]*try --voxel")
    message(FATAL_ERROR "a badly tracked run must end with what to try:\n${bad}")
  endif()
endif()
message(STATUS "sized: ${sized}")
