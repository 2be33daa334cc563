#include "edgefuse/memory/arena.hpp"

#include <cstring>

#include "edgefuse/board_config.hpp"

namespace edgefuse {
namespace {

constexpr MemoryMap kBuildMap = make_memory_map(kBuildBoard);
static_assert(kBuildMap.total_bytes <= kBuildBoard.ram_budget_bytes,
              "the static memory map exceeds the board's RAM budget: raise [memory] ram_budget_mib or "
              "lower the [capacity] values in board/<name>/board.toml");

// Compile-time check of every board the build knows, not only the one it targets.
constexpr bool all_boards_fit() {
  for (const BoardCapacities& b : kBoards)
    if (make_memory_map(b).total_bytes > b.ram_budget_bytes) return false;
  return true;
}
static_assert(all_boards_fit(), "a board's static memory map exceeds its RAM budget (board/*/board.toml)");

alignas(kRegionAlign) uint8_t g_arena[kBuildMap.total_bytes];

}  // namespace

uint8_t* static_arena() { return g_arena; }
uint64_t static_arena_bytes() { return sizeof(g_arena); }
const BoardCapacities& build_board() { return kBuildBoard; }
int board_count() { return kBoardCount; }
const BoardCapacities& board_at(int i) { return kBoards[i]; }
const BoardCapacities* find_board(const char* name) {
  for (const BoardCapacities& b : kBoards)
    if (std::strcmp(b.name, name) == 0) return &b;
  return nullptr;
}

}  // namespace edgefuse
