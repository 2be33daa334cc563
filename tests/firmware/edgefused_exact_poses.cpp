// edgefused with a pipeline of exact, fixed results (exact_pose_pipeline.hpp): the whole firmware
// (configuration, runtime, console, pose link, ports, service loop) for the end-to-end tests that
// check what arrives at the listeners against known poses.
#include "edgefused.hpp"
#include "exact_pose_pipeline.hpp"

namespace {
edgefuse_test::ExactPosePipeline g_pipeline;  // static: nothing of the runtime lives on the heap
}

int main(int argc, char** argv) { return edgefuse::firmware::run_edgefused(argc, argv, &g_pipeline); }
