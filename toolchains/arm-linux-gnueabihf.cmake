# Cross toolchain for board am335x (BeagleBone Black class, Cortex-A8 with NEON, hard-float ABI):
# Debian's arm-linux-gnueabihf g++. The test binaries run on the build host under qemu-user.
set(EDGEFUSE_CROSS_TRIPLET arm-linux-gnueabihf)
# Debian's armhf default is ARMv7-A + VFPv3-D16; the A8 also has NEON (and 32 D registers).
set(EDGEFUSE_CROSS_CPU_FLAGS "-mcpu=cortex-a8 -mfpu=neon -mfloat-abi=hard")
set(EDGEFUSE_CROSS_QEMU qemu-arm)
set(CMAKE_SYSTEM_PROCESSOR arm)
include("${CMAKE_CURRENT_LIST_DIR}/linux-cross-common.cmake")
# ARMv7 NEON is not IEEE (flush-to-zero) and has no float divide or sqrt: Eigen's NEON packets use
# reciprocal estimates there (about 1e-5 relative error in pose normalisation and inverses, seen
# in test_pose). Keep Eigen's float maths scalar on VFP, as exact as on the host; NEON remains for
# the compiler's integer (fixed-point) vectorisation. Global, so every TU agrees on Eigen's ABI.
string(APPEND CMAKE_CXX_FLAGS_INIT " -DEIGEN_DONT_VECTORIZE")
