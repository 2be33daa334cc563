# Cross toolchain for board rpi4 (Raspberry Pi 4, Cortex-A72): Debian's aarch64-linux-gnu g++.
# The test binaries run on the build host under qemu-user (CMAKE_CROSSCOMPILING_EMULATOR).
set(EDGEFUSE_CROSS_TRIPLET aarch64-linux-gnu)
set(EDGEFUSE_CROSS_CPU_FLAGS "-mcpu=cortex-a72")
set(EDGEFUSE_CROSS_QEMU qemu-aarch64)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
include("${CMAKE_CURRENT_LIST_DIR}/linux-cross-common.cmake")
