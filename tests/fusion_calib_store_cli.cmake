# ctest script on bin_rig_a: `edgefuse calibrate --from xtion --to tof --store DIR`: a new store gets
# seq 1 in calib_a.bin, the next save seq 2 in calib_b.bin (the other entries kept); a store with no
# valid slot is refused, naming the slot file, and left as it was.
# Variables: EDGEFUSE (CLI), DATA (shared data folder), WORK (scratch folder).
include(${CMAKE_CURRENT_LIST_DIR}/cli_script_helpers.cmake)
set(RIG ${DATA}/bin_rig_a)
begin_rig_script(${RIG})

set(store ${WORK}/store)
set(cal ${EDGEFUSE} calibrate ${RIG} --from xtion --to tof --frames 5 --store ${store})
run_ok(c1 ${cal})
run_ok(c2 ${cal})
if(NOT c1 MATCHES "stored T_xtion_tof in [^\n]*calib_a.bin \\(seq 1; new store\\)" OR
   NOT c2 MATCHES "stored T_xtion_tof in [^\n]*calib_b.bin \\(seq 2; kept the other entries of seq 1\\)")
  message(FATAL_ERROR "unexpected store lines:\n${c1}\n${c2}")
endif()
file(WRITE ${store}/calib_a.bin "garbage")
file(WRITE ${store}/calib_b.bin "garbage")
execute_process(COMMAND ${cal} OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc)
file(READ ${store}/calib_a.bin after)
if(rc EQUAL 0 OR NOT err MATCHES "calib_a.bin is [a-z ]+ and no slot is valid" OR NOT after STREQUAL "garbage")
  message(FATAL_ERROR "a store without a valid slot must be refused and kept (rc ${rc}):\n${err}")
endif()
message(STATUS "calibrate --store: seq 1, seq 2, corrupt store refused: ${err}")
