// edgefused's entry point: the firmware with the board's device pipeline.
#include "edgefused.hpp"

int main(int argc, char** argv) { return edgefuse::firmware::run_edgefused(argc, argv, nullptr); }
