// The build board's static arena: one cache-aligned byte array in .bss, sized at compile time by
// make_memory_map(kBuildBoard) and checked against the board's RAM budget. Programs carve it once
// at start-up with carve_memory(); nothing is allocated from the heap afterwards.
#pragma once

#include <cstdint>

#include "edgefuse/memory/memmap.hpp"

namespace edgefuse {

uint8_t* static_arena();
uint64_t static_arena_bytes();
//! The build board's capacities (from board/<EDGEFUSE_BOARD>/board.toml).
const BoardCapacities& build_board();
//! Capacities of a board by name, or null when the build knows no such board.
const BoardCapacities* find_board(const char* name);
//! Number of boards the build knows, and each by index (for listings).
int board_count();
const BoardCapacities& board_at(int i);

}  // namespace edgefuse
