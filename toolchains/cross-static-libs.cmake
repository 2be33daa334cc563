# Included after project() in the cross builds (CMAKE_PROJECT_INCLUDE, set by the toolchain files):
# find_library() and pkg-config imported targets then resolve to the sysroot's .a files, so the
# ARM binaries depend at run time only on libc/libstdc++, which qemu-user finds under /usr/<triplet>.
set(CMAKE_FIND_LIBRARY_SUFFIXES ".a")
