# Shared part of the Debian cross toolchain files. Expects EDGEFUSE_CROSS_TRIPLET,
# EDGEFUSE_CROSS_CPU_FLAGS and EDGEFUSE_CROSS_QEMU from the including file.
#
# Three roots are involved:
#  - /usr/<triplet>: libc and libstdc++ of the Debian cross compiler (libc6-dev-<arch>-cross,
#    libstdc++6-<arch>-cross); the compiler uses it by itself and qemu-user loads from it (-L).
#  - EDGEFUSE_SYSROOT: Debian's <arch> -dev packages unpacked by tools/sysroot.sh (CppUTest, libpng,
#    zlib, liblzf, toml++ headers). Static archives of it are linked, but for libpng, zlib and the
#    HAL's OpenNI2 / libudev: shared, as the board's packages provide them (the emulator below puts
#    the sysroot's library folders on the guest's LD_LIBRARY_PATH).
#  - the host: programs (cmake, python3) and the header-only Eigen (/usr/include/eigen3, found with
#    NO_CMAKE_FIND_ROOT_PATH by the top-level CMakeLists).
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_C_COMPILER "${EDGEFUSE_CROSS_TRIPLET}-gcc")
set(CMAKE_CXX_COMPILER "${EDGEFUSE_CROSS_TRIPLET}-g++")
set(CMAKE_C_FLAGS_INIT "${EDGEFUSE_CROSS_CPU_FLAGS}")
set(CMAKE_CXX_FLAGS_INIT "${EDGEFUSE_CROSS_CPU_FLAGS}")
# CMake cannot always infer the multiarch directory from a cross compiler's implicit link
# directories; without it find_library would miss <sysroot>/usr/lib/<triplet>.
set(CMAKE_LIBRARY_ARCHITECTURE "${EDGEFUSE_CROSS_TRIPLET}")

# The presets set EDGEFUSE_SYSROOT; the default keeps a plain `cmake -DCMAKE_TOOLCHAIN_FILE=...` usable.
set(EDGEFUSE_SYSROOT "${CMAKE_BINARY_DIR}/sysroot" CACHE PATH
    "Debian ${EDGEFUSE_CROSS_TRIPLET} -dev packages unpacked by tools/sysroot.sh")
# try_compile projects re-read this file with their own CMAKE_BINARY_DIR: hand them the real one.
list(APPEND CMAKE_TRY_COMPILE_PLATFORM_VARIABLES EDGEFUSE_SYSROOT)
get_property(_edgefuse_in_try_compile GLOBAL PROPERTY IN_TRY_COMPILE)
if(NOT _edgefuse_in_try_compile AND NOT EXISTS "${EDGEFUSE_SYSROOT}/.edgefuse-sysroot-stamp")
  if(EDGEFUSE_CROSS_TRIPLET STREQUAL "aarch64-linux-gnu")
    set(_edgefuse_deb_arch arm64)
  else()
    set(_edgefuse_deb_arch armhf)
  endif()
  message(FATAL_ERROR "No ${EDGEFUSE_CROSS_TRIPLET} sysroot at ${EDGEFUSE_SYSROOT}. Create it with:\n"
                      "  tools/sysroot.sh ${_edgefuse_deb_arch} ${EDGEFUSE_SYSROOT}\n"
                      "(tools/test does this for the aarch64 and armhf presets)")
endif()

set(CMAKE_FIND_ROOT_PATH "${EDGEFUSE_SYSROOT}" "/usr/${EDGEFUSE_CROSS_TRIPLET}")
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)   # build tools run on the host
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)    # never link a host (x86-64) library
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)    # never mix host headers of arch-specific libraries
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)
# pkg_check_modules() must read the sysroot's .pc files, with paths prefixed by the sysroot.
set(ENV{PKG_CONFIG_LIBDIR}
    "${EDGEFUSE_SYSROOT}/usr/lib/${EDGEFUSE_CROSS_TRIPLET}/pkgconfig:${EDGEFUSE_SYSROOT}/usr/share/pkgconfig")
set(ENV{PKG_CONFIG_SYSROOT_DIR} "${EDGEFUSE_SYSROOT}")

# find_library() takes only static archives (a later platform file resets the suffixes, so they
# are set again after project() by this hook).
set(CMAKE_PROJECT_INCLUDE "${CMAKE_CURRENT_LIST_DIR}/cross-static-libs.cmake")

find_program(EDGEFUSE_QEMU_EXECUTABLE "${EDGEFUSE_CROSS_QEMU}")
if(NOT EDGEFUSE_QEMU_EXECUTABLE)
  # Not fatal: building needs no emulator; ctest will fail to start the tests instead.
  set(EDGEFUSE_QEMU_EXECUTABLE "${EDGEFUSE_CROSS_QEMU}")
endif()
# ctest (and add_custom_command with a target as command) run the ARM binaries through qemu-user;
# -L makes the guest's dynamic loader and libc/libstdc++ come from the cross compiler's root, -E
# gives every guest the sysroot's shared libraries (libpng, zlib, OpenNI2, libudev: Debian keeps
# zlib in /lib/<triplet>, the others in /usr/lib/<triplet>).
set(CMAKE_CROSSCOMPILING_EMULATOR "${EDGEFUSE_QEMU_EXECUTABLE};-L;/usr/${EDGEFUSE_CROSS_TRIPLET};-E;LD_LIBRARY_PATH=${EDGEFUSE_SYSROOT}/usr/lib/${EDGEFUSE_CROSS_TRIPLET}:${EDGEFUSE_SYSROOT}/lib/${EDGEFUSE_CROSS_TRIPLET}")
