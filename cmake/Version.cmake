# The version of the programs and the packages, from git: a release tag vX.Y.Z gives X.Y.Z, a later
# commit X.Y.Z+<commits since the tag>.g<hash>; without tags the project's VERSION with
# +git<commit count>.g<hash> (the count keeps package versions increasing along a branch, so
# apt upgrades and rollbacks order them). A tree with uncommitted changes adds .dirty. Outside a git
# checkout (a source archive): the project's VERSION.
#
# Computed when CMake configures; a commit re-runs the configure step (the branch's ref is a
# configure dependency), so the programs never carry a stale version. tools/package configures
# anyway before packing.

function(edgefuse_git out_var)
  execute_process(COMMAND git ${ARGN} WORKING_DIRECTORY "${CMAKE_SOURCE_DIR}"
                  OUTPUT_VARIABLE text ERROR_QUIET RESULT_VARIABLE rc OUTPUT_STRIP_TRAILING_WHITESPACE)
  if(rc EQUAL 0)
    set(${out_var} "${text}" PARENT_SCOPE)
  else()
    set(${out_var} "" PARENT_SCOPE)
  endif()
endfunction()

# edgefuse_version_from_git(<out var>): sets <out var> and its configure dependencies.
function(edgefuse_version_from_git out_var)
  find_program(EDGEFUSE_GIT git)
  set(version "${PROJECT_VERSION}")
  if(EDGEFUSE_GIT)
    edgefuse_git(hash rev-parse --short=8 HEAD)
  endif()
  if(NOT EDGEFUSE_GIT OR hash STREQUAL "")
    set(${out_var} "${version}" PARENT_SCOPE)
    return()
  endif()
  edgefuse_git(described describe --tags --match "v[0-9]*" --long)
  if(described MATCHES "^v([0-9][0-9.]*)-([0-9]+)-g[0-9a-f]+$")
    set(version "${CMAKE_MATCH_1}")
    if(NOT CMAKE_MATCH_2 EQUAL 0)
      string(APPEND version "+${CMAKE_MATCH_2}.g${hash}")
    endif()
  else()
    edgefuse_git(count rev-list --count HEAD)
    string(APPEND version "+git${count}.g${hash}")
  endif()
  edgefuse_git(changes status --porcelain --untracked-files=no)
  if(NOT changes STREQUAL "")
    string(APPEND version ".dirty")
  endif()
  # Re-configure when HEAD moves: HEAD itself (a checkout) and the ref it names (a commit).
  edgefuse_git(head_file rev-parse --path-format=absolute --git-path HEAD)
  edgefuse_git(ref symbolic-ref -q HEAD)
  set(deps "${head_file}")
  if(NOT ref STREQUAL "")
    edgefuse_git(ref_file rev-parse --path-format=absolute --git-path "${ref}")
    if(EXISTS "${ref_file}")
      list(APPEND deps "${ref_file}")
    endif()
  endif()
  set_property(DIRECTORY "${CMAKE_SOURCE_DIR}" APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${deps})
  set(${out_var} "${version}" PARENT_SCOPE)
endfunction()
