// `edgefuse eval poses` and `edgefuse eval segments` (localisation accuracy, issue 5).
#pragma once

namespace edgefuse::cli {

int cmd_eval_poses(int argc, char** argv);
int cmd_eval_segments(int argc, char** argv);

}  // namespace edgefuse::cli
