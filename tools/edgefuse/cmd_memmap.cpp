// edgefuse memmap [--board NAME]: the static memory map of a board, buffer by buffer.
#include <cstdio>
#include <string>

#include "args.hpp"
#include "failure.hpp"
#include "commands.hpp"
#include "edgefuse/memory/arena.hpp"

namespace edgefuse::cli {

int cmd_memmap(int argc, char** argv) {
  const char* usage =
      "usage: edgefuse memmap [--board NAME]\n"
      "  Prints the board's static memory map: every large buffer, its size and offset in the arena,\n"
      "  and the total against the board's RAM budget (default: the build's board).\n";
  if (help_asked(argc, argv, usage)) return 0;
  Args args;
  std::string err;
  if (!args.parse(argc, argv, {"board"}, {}, err) || !args.positional().empty()) {
    std::fprintf(stderr, "edgefuse memmap: %s\n%s", err.empty() ? "unexpected argument" : err.c_str(), usage);
    return 2;
  }
  const std::string name = args.get("board", build_board().name);
  const BoardCapacities* b = find_board(name.c_str());
  if (b == nullptr) {
    std::fprintf(stderr, "edgefuse memmap: unknown board '%s'; known:", name.c_str());
    for (int i = 0; i < board_count(); ++i) std::fprintf(stderr, " %s", board_at(i).name);
    std::fprintf(stderr, "\n");
    return 1;
  }
  const MemoryMap m = make_memory_map(*b);
  std::printf("board %s: space up to %d^3, a pool of %u bricks of 8^3 voxels%s, images up to %dx%d x %d sensors, %u "
              "points, %d objects, %s build\n",
              b->name, b->volume_dim, b->pool_bricks, b->colour ? " with colour" : "", b->image_width_max,
              b->image_height_max, b->sensors_max,
              b->points_max, b->objects_max, b->fixed_point ? "fixed-point" : "float");
  std::printf("%-30s %14s %10s\n", "buffer", "bytes", "MiB");
  for (const MemoryRegion& r : m.regions)
    std::printf("%-30s %14llu %10.2f\n", r.name, static_cast<unsigned long long>(r.bytes), double(r.bytes) / 1048576.0);
  std::printf("%-30s %14llu %10.2f\n", "total (64-byte aligned)", static_cast<unsigned long long>(m.total_bytes),
              double(m.total_bytes) / 1048576.0);
  std::printf("%-30s %14llu %10.2f  (%.0f%% used)\n", "RAM budget", static_cast<unsigned long long>(b->ram_budget_bytes),
              double(b->ram_budget_bytes) / 1048576.0, 100.0 * double(m.total_bytes) / double(b->ram_budget_bytes));
  return 0;
}

}  // namespace edgefuse::cli
