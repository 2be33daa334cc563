// The firmware program, edgefused: reads the board data and the runtime configuration, assembles
// the HAL devices, the pipeline, the runtime, the pose link and the console, and serves them until
// SIGTERM/SIGINT (see edgefused.cpp). A test program runs the same firmware with a pipeline of its
// own (tests/firmware/edgefused_exact_poses.cpp).
#pragma once

#include "edgefuse/runtime/pipeline.hpp"

namespace edgefuse::firmware {

//! Runs edgefused. \param argc \param argv its command line
//! \param pipeline null: the board's device pipeline (DevicePipeline); a test may give its own
//! \return the exit code
int run_edgefused(int argc, char** argv, runtime::Pipeline* pipeline);

}  // namespace edgefuse::firmware
