// edgefuse: the host-side command-line program. A static table of subcommands, one file each.
#include <cstdio>
#include <cstring>

#include "commands.hpp"
#include "edgefuse/math/real.hpp"
#include "edgefuse/memory/arena.hpp"

namespace {

struct Command {
  const char* name;
  int (*run)(int argc, char** argv);
  const char* summary;
};

const Command kCommands[] = {
    {"fuse", edgefuse::cli::cmd_fuse, "integrate a data set at its ground-truth poses, write the cloud / mesh"},
    {"memmap", edgefuse::cli::cmd_memmap, "print a board's static memory map"},
    {"track", edgefuse::cli::cmd_track, "track the sensor by ICP against the fused model, fuse, write the trajectory"},
    {"eval", edgefuse::cli::cmd_eval, "accuracy against ground truth: trajectories (ate, rpe as TUM's tools), object poses, segments"},
    // multi-sensor fusion
    {"calibrate", edgefuse::cli::cmd_calibrate, "find the mounting T_A_B of two rigidly mounted sensors from the data"},
    {"handeye", edgefuse::cli::cmd_handeye, "find the camera's mounting on a robot flange from robot poses and the data"},
    // pose link
    {"listen", edgefuse::cli::cmd_listen, "decode and print the pose link (serial, TCP, UDP or a captured file)"},
    // localisation
    {"localize", edgefuse::cli::cmd_localize, "object poses (--model FILE.ply ...) or model-free segments (--segments)"},
    // HAL
    {"acquire", edgefuse::cli::cmd_acquire, "run the board's cameras through the acquisition runtime, print status"},
    // pictures
    {"render", edgefuse::cli::cmd_render, "draw a fused cloud and the localised objects into a PNG"},
};

void usage(std::FILE* out) {
  std::fprintf(out, "usage: edgefuse COMMAND [ARGS]   (board %s, %s build)\n", edgefuse::build_board().name,
               edgefuse::kFixedPointBuild ? "fixed-point" : "float");
  for (const Command& c : kCommands) std::fprintf(out, "  %-9s %s\n", c.name, c.summary);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || !std::strcmp(argv[1], "help") || !std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h")) {
    usage(argc < 2 ? stderr : stdout);
    return argc < 2 ? 2 : 0;
  }
  for (const Command& c : kCommands)
    if (!std::strcmp(argv[1], c.name)) return c.run(argc - 2, argv + 2);
  std::fprintf(stderr, "edgefuse: unknown command '%s'\n", argv[1]);
  usage(stderr);
  return 2;
}
