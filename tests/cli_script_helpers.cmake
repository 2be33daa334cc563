# Helpers shared by the ctest scripts that drive the edgefuse CLI on a rig set (fusion_*_cli.cmake).

# Skips the test when the rig set is missing, else empties the scratch folder WORK. A macro, not a
# function: its return() leaves the calling script (a return() in an included file or a function
# would only leave those).
macro(begin_rig_script rig)
  if(NOT EXISTS ${rig}/rig.toml)
    message(STATUS "skipped: ${rig} not found (set EDGEFUSE_SHARED_DATA)")
    return()
  endif()
  file(REMOVE_RECURSE ${WORK})
  file(MAKE_DIRECTORY ${WORK})
endmacro()

# Runs a command; fails the test with its output when it exits non-zero, else stores stdout.
function(run_ok out_var)
  execute_process(COMMAND ${ARGN} OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "failed (${rc}): ${ARGN}\n${out}\n${err}")
  endif()
  set(${out_var} "${out}" PARENT_SCOPE)
endfunction()

# Stores the first capture group of `regex` in `text`; fails the test naming `what` when absent.
function(match_value text regex what out_var)
  string(REGEX MATCH "${regex}" m "${text}")
  if(NOT m)
    message(FATAL_ERROR "no ${what} in:\n${text}")
  endif()
  set(${out_var} ${CMAKE_MATCH_1} PARENT_SCOPE)
endfunction()
