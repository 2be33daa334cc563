# Included after project() in the cross builds (CMAKE_PROJECT_INCLUDE, set by the toolchain files):
# find_library() and pkg-config imported targets then resolve to the sysroot's .a files, so the
# ARM binaries depend at run time on libc/libstdc++ (qemu-user finds them under /usr/<triplet>) and
# on the few shared libraries found on purpose: libpng and zlib (tools/formats), the HAL's OpenNI2
# and libudev (hal/), which the emulator loads from the sysroot (linux-cross-common.cmake).
set(CMAKE_FIND_LIBRARY_SUFFIXES ".a")
