# ctest script (fusion round 4, issue 4) on bin_rig_a: `edgefuse fuse --sensors xtion,tof --frames 5`
#  - the push lines report the depth-jump limit: the xtion's stays at the truncation (8.0 mm), the
#    ToF's follows its noise (2.83 x ~6.6 mm, checked within 15-25 mm);
#  - the support rule removes points: the default cloud has fewer points than the same run with
#    `--min-support 0` (and both more than zero);
#  - a bad value is refused naming the option.
# Variables: EDGEFUSE (CLI), DATA (shared data folder), WORK (scratch folder).
include(${CMAKE_CURRENT_LIST_DIR}/cli_script_helpers.cmake)
set(RIG ${DATA}/bin_rig_a)
begin_rig_script(${RIG})

set(fuse ${EDGEFUSE} fuse ${RIG} --sensors xtion,tof --frames 5 --origin -0.256,-0.256,-0.2)
run_ok(def ${fuse} --out ${WORK}/default.ply)
run_ok(off ${fuse} --min-support 0 --out ${WORK}/no_support.ply)
if(NOT def MATCHES "xtion: 5 frames pushed \\([^)]*depth jump 8\\.0 mm\\)")
  message(FATAL_ERROR "the xtion's jump limit must stay at the truncation:\n${def}")
endif()
string(REGEX MATCH "tof: 5 frames pushed \\([^)]*depth jump ([0-9.]+) mm\\)" m "${def}")
if(NOT m OR CMAKE_MATCH_1 LESS 15 OR CMAKE_MATCH_1 GREATER 25)
  message(FATAL_ERROR "the ToF's jump limit must follow its noise (15-25 mm):\n${def}")
endif()
set(tof_jump ${CMAKE_MATCH_1})
match_value("${def}" "points=([0-9]+)" "points=" n_def)
match_value("${off}" "points=([0-9]+)" "points=" n_off)
if(n_def EQUAL 0 OR NOT n_def LESS n_off)
  message(FATAL_ERROR "the support rule must remove points (default ${n_def}, --min-support 0 ${n_off})")
endif()
execute_process(COMMAND ${fuse} --min-support 300 OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc)
if(NOT rc EQUAL 2 OR NOT err MATCHES "--min-support must be an integer")
  message(FATAL_ERROR "--min-support 300 must be refused (rc ${rc}):\n${err}")
endif()
message(STATUS "ToF depth jump ${tof_jump} mm; points ${n_def} with the support rule, ${n_off} without")
