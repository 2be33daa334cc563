# ctest script (fusion rounds 5 and 5b, issue 4) on bin_rig_a, 5 frames:
#  - round 5b: `fuse --sensors xtion,tof` fills the ToF's sub-unit samples only to 3 units (mixed set)
#    and takes support 4; `--sub-unit-fill 8` gives round 5's default, the evidence rule (support 9);
#    `--full-coverage` round 4's fill 8 / support 4 with the most points; `--sensors xtion` alone 8 / 4;
#  - the cloud and the mesh follow the rule (fewer points and vertices than --full-coverage);
#  - the PLY carries the per-point evidence (`property uchar support`);
#  - `--full-coverage` with `--min-support`, with `--sub-unit-fill` or with `--no-trust`, is refused
#    (exit 2) naming the option; `--sub-unit-fill 0` is refused (exit 2) naming it.
# (Round 5 expected support 9 for the default of xtion,tof; round 5b's default changed that, see
# BENCHMARKS "Multi-sensor fusion, round 5b".)
# Variables: EDGEFUSE (CLI), DATA (shared data folder), WORK (scratch folder).
include(${CMAKE_CURRENT_LIST_DIR}/cli_script_helpers.cmake)
set(RIG ${DATA}/bin_rig_a)
begin_rig_script(${RIG})

set(fuse ${EDGEFUSE} fuse ${RIG} --frames 5 --origin -0.256,-0.256,-0.2)
run_ok(ev ${fuse} --sensors xtion,tof --out ${WORK}/evidence.ply --mesh ${WORK}/evidence_mesh.ply)
run_ok(fc ${fuse} --sensors xtion,tof --full-coverage --out ${WORK}/full.ply --mesh ${WORK}/full_mesh.ply)
run_ok(xt ${fuse} --sensors xtion --out ${WORK}/xtion.ply)
run_ok(r5 ${fuse} --sensors xtion,tof --sub-unit-fill 8 --out ${WORK}/round5.ply)
if(NOT ev MATCHES "fill a voxel up to 3 weight units \\(default, mixed set\\)"
   OR NOT ev MATCHES "support rule: both voxels of a crossing hold >= 4 weight units \\(default\\)")
  message(FATAL_ERROR "xtion,tof must fill sub-unit samples to 3 and take support 4:\n${ev}")
endif()
if(NOT r5 MATCHES "support rule: both voxels of a crossing hold >= 9 weight units \\(default, evidence rule")
  message(FATAL_ERROR "xtion,tof with --sub-unit-fill 8 must take the evidence rule (9):\n${r5}")
endif()
if(NOT fc MATCHES "up to 8 weight units \\(--full-coverage\\)" OR NOT xt MATCHES "up to 8 weight units \\(default\\)")
  message(FATAL_ERROR "--full-coverage and the xtion alone must keep the fill of 8:\n${fc}\n${xt}")
endif()
if(NOT fc MATCHES ">= 4 weight units \\(--full-coverage\\)" OR NOT xt MATCHES ">= 4 weight units \\(default\\)")
  message(FATAL_ERROR "--full-coverage and the xtion alone must take support 4:\n${fc}\n${xt}")
endif()
match_value("${ev}" "points=([0-9]+)" "points=" n_ev)
match_value("${fc}" "points=([0-9]+)" "points=" n_fc)
match_value("${ev}" "mesh: ([0-9]+) vertices" "mesh vertices" v_ev)
match_value("${fc}" "mesh: ([0-9]+) vertices" "mesh vertices" v_fc)
if(n_ev EQUAL 0 OR NOT n_ev LESS n_fc OR v_ev EQUAL 0 OR NOT v_ev LESS v_fc)
  message(FATAL_ERROR "the default (fill 3, support 4) must keep fewer points and mesh vertices than --full-coverage "
                      "(points ${n_ev} / ${n_fc}, vertices ${v_ev} / ${v_fc})")
endif()
file(READ ${WORK}/evidence.ply head LIMIT 400)
if(NOT head MATCHES "property uchar support\nend_header")
  message(FATAL_ERROR "the fused PLY must carry the per-point support:\n${head}")
endif()
foreach(bad "--full-coverage;--min-support;3" "--full-coverage;--no-trust" "--full-coverage;--sub-unit-fill;3")
  execute_process(COMMAND ${fuse} --sensors xtion,tof ${bad} --out ${WORK}/bad.ply OUTPUT_VARIABLE out ERROR_VARIABLE err
                  RESULT_VARIABLE rc)
  if(NOT rc EQUAL 2 OR NOT err MATCHES "--full-coverage")
    message(FATAL_ERROR "${bad} must be refused with exit 2 naming --full-coverage (rc ${rc}):\n${err}")
  endif()
endforeach()
execute_process(COMMAND ${fuse} --sensors xtion,tof --sub-unit-fill 0 --out ${WORK}/bad.ply OUTPUT_VARIABLE out
                ERROR_VARIABLE err RESULT_VARIABLE rc)
if(NOT rc EQUAL 2 OR NOT err MATCHES "sub-unit-fill")
  message(FATAL_ERROR "--sub-unit-fill 0 must be refused with exit 2 naming the option (rc ${rc}):\n${err}")
endif()
match_value("${r5}" "points=([0-9]+)" "points=" n_r5)
message(STATUS "5 frames xtion,tof: ${n_r5} points with round 5's evidence rule (--sub-unit-fill 8)")
message(STATUS "5 frames xtion,tof: ${n_ev} points / ${v_ev} mesh vertices with the evidence rule, "
               "${n_fc} / ${v_fc} with --full-coverage")
