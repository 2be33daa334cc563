# Install rules and the Debian package of this build (CPack's DEB generator): one package per
# preset, for the build's board and architecture (host: amd64 / host-sim, aarch64: arm64 / rpi4,
# armhf: armhf / am335x). tools/package builds them; tests/package_install.py unpacks and runs one.
#
#   /usr/bin/edgefused, /usr/bin/edgefuse
#   /usr/share/edgefuse/board/<board>/         the build's board data (board.toml, hal.toml, ...)
#   /etc/edgefuse/edgefused.toml               board/<board>/edgefused.toml, a conffile
#   /lib/systemd/system/edgefused.service      tools/packaging/edgefused.service
#   /lib/udev/rules.d/60-edgefuse.rules        generated below from board/<board>/hal.toml
#   /usr/share/doc/edgefuse/                   copyright, changelog.gz, DEPLOY.md
#   /var/lib/edgefuse                          the calibration store: made by postinst and systemd
#
# The programs find their board data relative to their own folder (board_data_dir.hpp), so the
# relocatable part honours CMAKE_INSTALL_PREFIX; the system files (/etc, /lib) are absolute, as
# Debian wants them (use DESTDIR to install the tree elsewhere). The package is built from the
# already built tree: `install` does not build `all` (CMAKE_SKIP_INSTALL_ALL_DEPENDENCY, set
# before this file), tools/package builds the installed targets first.

set(EDGEFUSE_PACKAGE_MAINTAINER "edgefuse maintainers <edgefuse@example.org>" CACHE STRING
    "Maintainer field of the Debian packages")
set(_pkg_dir "${CMAKE_SOURCE_DIR}/tools/packaging")
set(_board_dir "${CMAKE_SOURCE_DIR}/board/${EDGEFUSE_BOARD}")
set(_staged "${CMAKE_BINARY_DIR}/packaging")

# --- programs and board data ---------------------------------------------------------------------
install(TARGETS edgefused edgefuse RUNTIME DESTINATION bin)
install(DIRECTORY "${_board_dir}/" DESTINATION share/edgefuse/board/${EDGEFUSE_BOARD}
        PATTERN "edgefused.toml" EXCLUDE)
if(NOT EXISTS "${_board_dir}/edgefused.toml")
  message(FATAL_ERROR "board ${EDGEFUSE_BOARD}: no ${_board_dir}/edgefused.toml (the installed runtime configuration)")
endif()
install(FILES "${_board_dir}/edgefused.toml" DESTINATION /etc/edgefuse)
install(FILES "${_pkg_dir}/edgefused.service" DESTINATION /lib/systemd/system)

# --- udev rules from the board's hal.toml ---------------------------------------------------------
# edgefuse_udev_rules(<hal.toml> <out var>): one rule per camera with usb_vid / usb_pid (its USB
# device node to the group edgefuse: OpenNI2 and libusb open it; V4L2 nodes are the group video's
# anyway) and one per GPIO chip a [[pin]] names (to the group gpio, as Raspberry Pi OS does).
# The group edgefuse rather than plugdev: the camera is for edgefused, not for every desktop user.
function(edgefuse_udev_rules hal_file out_var)
  file(STRINGS "${hal_file}" lines)
  set(rules "")
  set(name "")
  set(vid "")
  foreach(line IN LISTS lines)
    string(REGEX REPLACE "#.*$" "" line "${line}")
    if(line MATCHES "^[ \t]*\\[\\[")
      set(name "")
      set(vid "")
    elseif(line MATCHES "^[ \t]*name[ \t]*=[ \t]*\"([^\"]*)\"")
      set(name "${CMAKE_MATCH_1}")
    elseif(line MATCHES "^[ \t]*usb_vid[ \t]*=[ \t]*0x([0-9a-fA-F]+)")
      string(TOLOWER "${CMAKE_MATCH_1}" vid)
    elseif(line MATCHES "^[ \t]*usb_pid[ \t]*=[ \t]*0x([0-9a-fA-F]+)")
      string(TOLOWER "${CMAKE_MATCH_1}" pid)
      string(APPEND rules "# camera ${name}\nSUBSYSTEM==\"usb\", ENV{DEVTYPE}==\"usb_device\", "
             "ATTR{idVendor}==\"${vid}\", ATTR{idProduct}==\"${pid}\", GROUP=\"edgefuse\", MODE=\"0660\"\n")
    elseif(line MATCHES "^[ \t]*chip[ \t]*=[ \t]*\"(gpiochip[0-9]+)\"")
      string(APPEND rules "# pin ${name}\nSUBSYSTEM==\"gpio\", KERNEL==\"${CMAKE_MATCH_1}\", GROUP=\"gpio\", MODE=\"0660\"\n")
    endif()
  endforeach()
  set(${out_var} "${rules}" PARENT_SCOPE)
endfunction()
edgefuse_udev_rules("${_board_dir}/hal.toml" _rules)
if(_rules STREQUAL "")
  set(_rules "# (board ${EDGEFUSE_BOARD}'s hal.toml names no USB camera and no GPIO chip)\n")
endif()
file(CONFIGURE OUTPUT "${_staged}/60-edgefuse.rules" CONTENT
"# Generated from board/${EDGEFUSE_BOARD}/hal.toml by cmake/Packaging.cmake: the board's cameras
# and GPIO chips for edgefused's user (edgefuse, in the groups edgefuse and gpio).
${_rules}" @ONLY)
install(FILES "${_staged}/60-edgefuse.rules" DESTINATION /lib/udev/rules.d)

# --- documentation: copyright, changelog (Debian wants both), the deployment manual ---------------
edgefuse_git(_commit rev-parse HEAD)
edgefuse_git(_commit_date log -1 --format=%aD)
if(_commit_date STREQUAL "")
  string(TIMESTAMP _commit_date "%a, %d %b %Y %H:%M:%S +0000" UTC)
endif()
file(CONFIGURE OUTPUT "${_staged}/changelog" CONTENT
"edgefuse (${EDGEFUSE_VERSION}) unstable; urgency=medium

  * Built from git commit ${_commit}.

 -- ${EDGEFUSE_PACKAGE_MAINTAINER}  ${_commit_date}
" @ONLY)
# gzip -n: no name or time stamp in the archive (reproducible, as lintian asks).
execute_process(COMMAND gzip -9nf "${_staged}/changelog" -c OUTPUT_FILE "${_staged}/changelog.gz")
install(FILES "${_pkg_dir}/copyright" "${_staged}/changelog.gz" "${CMAKE_SOURCE_DIR}/docs/DEPLOY.md"
        DESTINATION share/doc/edgefuse)

# --- the Debian package --------------------------------------------------------------------------
if(CMAKE_CROSSCOMPILING)
  if(CMAKE_SYSTEM_PROCESSOR STREQUAL "aarch64")
    set(_deb_arch arm64)
  else()
    set(_deb_arch armhf)
  endif()
else()
  execute_process(COMMAND dpkg --print-architecture OUTPUT_VARIABLE _deb_arch OUTPUT_STRIP_TRAILING_WHITESPACE)
endif()
# The run-time libraries of the cross builds (everything else is linked statically, see
# toolchains/cross-static-libs.cmake and tools/formats/CMakeLists.txt), by soname: tests/package_install.py checks that the
# installed programs need no other. Declared here because dpkg-shlibdeps cannot work on the
# sysroot: tools/sysroot.sh unpacks the ARM packages without dpkg's database (no shlibs files).
# Lower bounds: bookworm's versions of the libraries the sysroot holds.
set(EDGEFUSE_CROSS_RUNTIME_SONAMES
  "libc.so.6=libc6 (>= 2.36)"
  "ld-linux-aarch64.so.1=libc6 (>= 2.36)"
  "ld-linux-armhf.so.3=libc6 (>= 2.36)"
  "libm.so.6=libc6 (>= 2.36)"
  "libstdc++.so.6=libstdc++6 (>= 12)"
  "libgcc_s.so.1=libgcc-s1 (>= 3.0)"
  "libOpenNI2.so.0=libopenni2-0 (>= 2.2.0.33)"
  "libudev.so.1=libudev1 (>= 183)"
  "libpng16.so.16=libpng16-16 (>= 1.6.39)"
  "libz.so.1=zlib1g (>= 1:1.2.13)")
set(_depends "adduser")
if(CMAKE_CROSSCOMPILING)
  foreach(_entry IN LISTS EDGEFUSE_CROSS_RUNTIME_SONAMES)
    string(FIND "${_entry}" "=" _eq)
    math(EXPR _eq "${_eq} + 1")
    string(SUBSTRING "${_entry}" ${_eq} -1 _dep)
    string(FIND "${_depends}" "${_dep}" _seen)
    if(_seen EQUAL -1)
      string(APPEND _depends ", ${_dep}")
    endif()
  endforeach()
endif()

set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME edgefuse)
set(CPACK_PACKAGE_VERSION "${EDGEFUSE_VERSION}")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_STRIP_FILES TRUE)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_ARCHITECTURE "${_deb_arch}")
set(CPACK_DEBIAN_PACKAGE_MAINTAINER "${EDGEFUSE_PACKAGE_MAINTAINER}")
set(CPACK_DEBIAN_PACKAGE_SECTION misc)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "depth fusion and object localisation for a robot gripper (board ${EDGEFUSE_BOARD})")
# The extended description only: CPack puts the summary before it as the synopsis.
set(CPACK_DEBIAN_PACKAGE_DESCRIPTION "edgefused fuses the depth cameras of board ${EDGEFUSE_BOARD} into a TSDF map,
localises the objects in it and sends their poses to the robot controller over
TCP, UDP or a serial line. It runs as the systemd service edgefused under the
system user edgefuse. edgefuse is the command-line tool for recordings,
calibration and the pose link. See /usr/share/doc/edgefuse/DEPLOY.md.")
set(CPACK_DEBIAN_PACKAGE_DEPENDS "${_depends}")
if(NOT CMAKE_CROSSCOMPILING)
  set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
endif()
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA "${_pkg_dir}/debian/conffiles;${_pkg_dir}/debian/postinst;${_pkg_dir}/debian/prerm;${_pkg_dir}/debian/postrm")
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION TRUE)
set(CPACK_PACKAGE_DIRECTORY "${CMAKE_BINARY_DIR}/package")
include(CPack)
