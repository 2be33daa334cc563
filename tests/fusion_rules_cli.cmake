# ctest script on bin_rig_a, 5 frames: the noise rules of `edgefuse fuse --sensors`
# (fusion_rules.hpp) as the CLI applies them.
#  - The push lines report the depth-jump limit: the xtion's stays at the truncation (8.0 mm), the
#    ToF's follows its noise (2.83 x ~6.6 mm, checked within 15-25 mm).
#  - `--sensors xtion,tof` mixes a sub-unit camera (the ToF) with a unit-sized one: sub-unit samples
#    fill a voxel only to 3 units, and the support rule is 4; the xtion alone fills to 8 (one
#    sample) with support 4. `--no-trust` applies no rule.
#  - The cloud and the mesh are not empty, and the PLY carries the per-point evidence
#    (`property uchar support`).
# Variables: EDGEFUSE (CLI), DATA (shared data folder), WORK (scratch folder).
include(${CMAKE_CURRENT_LIST_DIR}/cli_script_helpers.cmake)
set(RIG ${DATA}/bin_rig_a)
begin_rig_script(${RIG})

set(fuse ${EDGEFUSE} fuse ${RIG} --frames 5 --origin -0.256,-0.256,-0.2)
run_ok(mix ${fuse} --sensors xtion,tof --out ${WORK}/mixed.ply --mesh ${WORK}/mixed_mesh.ply)
run_ok(xt ${fuse} --sensors xtion --out ${WORK}/xtion.ply)
run_ok(eq ${fuse} --sensors xtion,tof --no-trust --out ${WORK}/equal.ply)

if(NOT mix MATCHES "xtion: 5 frames pushed \\([^)]*depth jump 8\\.0 mm\\)")
  message(FATAL_ERROR "the xtion's jump limit must stay at the truncation:\n${mix}")
endif()
string(REGEX MATCH "tof: 5 frames pushed \\([^)]*depth jump ([0-9.]+) mm\\)" m "${mix}")
if(NOT m OR CMAKE_MATCH_1 LESS 15 OR CMAKE_MATCH_1 GREATER 25)
  message(FATAL_ERROR "the ToF's jump limit must follow its noise (15-25 mm):\n${mix}")
endif()
set(tof_jump ${CMAKE_MATCH_1})

if(NOT mix MATCHES "fill a voxel up to 3 weight units \\(mixed set\\)"
   OR NOT mix MATCHES "support rule: both voxels of a crossing hold >= 4 weight units\n")
  message(FATAL_ERROR "xtion,tof must fill sub-unit samples to 3 and take support 4:\n${mix}")
endif()
if(NOT xt MATCHES "fill a voxel up to 8 weight units \\(one sample\\)"
   OR NOT xt MATCHES "support rule: both voxels of a crossing hold >= 4 weight units\n")
  message(FATAL_ERROR "the xtion alone must fill to 8 and take support 4:\n${xt}")
endif()
if(eq MATCHES "support rule:" OR eq MATCHES "sub-unit fill:" OR eq MATCHES "depth jump")
  message(FATAL_ERROR "--no-trust must apply none of the noise rules:\n${eq}")
endif()

match_value("${mix}" "points=([0-9]+)" "points=" n_mix)
match_value("${mix}" "mesh: ([0-9]+) vertices" "mesh vertices" v_mix)
if(n_mix EQUAL 0 OR v_mix EQUAL 0)
  message(FATAL_ERROR "empty cloud or mesh:\n${mix}")
endif()
file(READ ${WORK}/mixed.ply head LIMIT 400)
if(NOT head MATCHES "property uchar support\nend_header")
  message(FATAL_ERROR "the fused PLY must carry the per-point support:\n${head}")
endif()
message(STATUS "5 frames xtion,tof: ToF depth jump ${tof_jump} mm; ${n_mix} points, ${v_mix} mesh vertices")
