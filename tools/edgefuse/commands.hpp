// The subcommands of the edgefuse program; each returns the process exit code
// (0 ok, 1 bad input or failure, 2 bad command line).
#pragma once

namespace edgefuse::cli {

int cmd_fuse(int argc, char** argv);
int cmd_memmap(int argc, char** argv);
int cmd_track(int argc, char** argv);
int cmd_eval(int argc, char** argv);
// multi-sensor fusion
int cmd_calibrate(int argc, char** argv);
int cmd_fuse_rig(int argc, char** argv);  //!< `fuse RIGSET --sensors ...` (called by cmd_fuse)
int cmd_handeye(int argc, char** argv);   //!< the camera's mounting on a robot flange (AX = XB)
// pose link
int cmd_listen(int argc, char** argv);
// localisation
int cmd_localize(int argc, char** argv);
int cmd_acquire(int argc, char** argv);  // HAL
int cmd_render(int argc, char** argv);   //!< a PNG of a fused cloud and the localised objects

}  // namespace edgefuse::cli
