// The subcommands of the edgefuse program; each returns the process exit code
// (0 ok, 1 bad input or failure, 2 bad command line).
#pragma once

namespace edgefuse::cli {

int cmd_fuse(int argc, char** argv);
int cmd_memmap(int argc, char** argv);
int cmd_track(int argc, char** argv);
int cmd_eval(int argc, char** argv);
// multi-sensor fusion (issue 4)
int cmd_calibrate(int argc, char** argv);
int cmd_fuse_rig(int argc, char** argv);  //!< `fuse RIGSET --sensors ...` (called by cmd_fuse)
// pose link (issue 7, feat/link)
int cmd_listen(int argc, char** argv);
// localisation (issue 5)
int cmd_localize(int argc, char** argv);
int cmd_acquire(int argc, char** argv);  // HAL (issue 6)

}  // namespace edgefuse::cli
