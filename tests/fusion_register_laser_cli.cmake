# ctest script on bin_rig_a, 5 frames: `edgefuse fuse --sensors xtion,tof,laser --register-laser`
# registers the line scanner's profiles against the space the cameras filled.
#  - On a copy of the set whose scanner poses are all 2.7 mm off (tools/bench/scanner_offset_rig.py:
#    T * offset, offset 2, -1.5, 1 mm in the sensor frame) the registration moves the first profile
#    back onto its true pose: its move from the recorded pose is minus the offset, within 0.5 mm on
#    every axis. Without --register-laser it is integrated where recorded (0 mm).
#  - On the set's own (exact) poses the registration moves it by less than 0.5 mm.
# Variables: EDGEFUSE (CLI), DATA (shared data folder), WORK (scratch folder), PYTHON, SOURCE_DIR.
include(${CMAKE_CURRENT_LIST_DIR}/cli_script_helpers.cmake)
set(RIG ${DATA}/bin_rig_a)
begin_rig_script(${RIG})
if(NOT EXISTS ${PYTHON})
  message(STATUS "skipped: ${PYTHON} not found")
  return()
endif()

set(OFF_RIG ${WORK}/rig_scanner_off)
run_ok(mk ${PYTHON} ${SOURCE_DIR}/tools/bench/scanner_offset_rig.py ${RIG} ${OFF_RIG} --offset 0.002,-0.0015,0.001)
set(moved_re "first profile's pose as integrated is ([0-9.]+) mm, [0-9.]+ deg from the recorded pose \\(t (-?[0-9.]+) (-?[0-9.]+) (-?[0-9.]+) mm")

run_ok(plain ${EDGEFUSE} fuse ${OFF_RIG} --sensors xtion,tof,laser --frames 5 --out ${WORK}/plain.ply)
match_value("${plain}" "${moved_re}" "pose line" m_plain)
run_ok(reg ${EDGEFUSE} fuse ${OFF_RIG} --sensors xtion,tof,laser --frames 5 --register-laser --out ${WORK}/registered.ply)
string(REGEX MATCH "${moved_re}" m "${reg}")
if(NOT m)
  message(FATAL_ERROR "no pose line in:\n${reg}")
endif()
set(m_reg ${CMAKE_MATCH_1})
set(mx ${CMAKE_MATCH_2})
set(my ${CMAKE_MATCH_3})
set(mz ${CMAKE_MATCH_4})
message(STATUS "scanner poses 2.7 mm off: moved ${m_plain} mm without, ${m_reg} mm (${mx} ${my} ${mz}) with --register-laser")
if(NOT m_plain LESS 0.001 OR mx LESS -2.5 OR mx GREATER -1.5 OR my LESS 1.0 OR my GREATER 2.0 OR mz LESS -1.5
   OR mz GREATER -0.5)
  message(FATAL_ERROR "expected 0 mm without and (-2.0 1.5 -1.0) +- 0.5 mm with --register-laser:\n${reg}")
endif()

run_ok(exact ${EDGEFUSE} fuse ${RIG} --sensors xtion,tof,laser --frames 5 --register-laser --out ${WORK}/exact.ply)
match_value("${exact}" "${moved_re}" "pose line" m_exact)
message(STATUS "exact scanner poses: moved ${m_exact} mm by --register-laser")
if(NOT m_exact LESS 0.5)
  message(FATAL_ERROR "on exact poses the registration must stay within 0.5 mm:\n${exact}")
endif()
