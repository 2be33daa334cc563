// The static memory map: sizes derive from the board capacities, the build board fits its budget,
// the arena carves into aligned, disjoint regions.
#include <cstdint>
#include <cstring>

#include "edgefuse/memory/arena.hpp"
#include "test_support.hpp"

using namespace edgefuse;

TEST_GROUP(MemMap){};

// Voxels live in the pool (the board's pool_bricks), compact; the per-brick arrays (index, flags,
// work list) cover the whole cube the index spans.
TEST(MemMap, VoxelRegionsAreCompact) {
  const BoardCapacities* b = find_board("host-sim");
  CHECK(b != nullptr);
  const MemoryMap m = make_memory_map(*b);
  const uint64_t voxels = uint64_t(b->pool_bricks) * kBrickVoxels;
  const uint64_t cube_bricks = 512ull * 512 * 512 / kBrickVoxels;
  CHECK_EQUAL(512, b->volume_dim);
  CHECK(b->pool_bricks < cube_bricks);  // memory follows the surface, not the cube
  CHECK_EQUAL(voxels * 2, m.regions[int(Region::kVoxelTsdf)].bytes);
  CHECK_EQUAL(voxels, m.regions[int(Region::kVoxelWeight)].bytes);
  CHECK_EQUAL(voxels * 3, m.regions[int(Region::kVoxelColour)].bytes);
  CHECK_EQUAL(cube_bricks * 4, m.regions[int(Region::kBrickSlots)].bytes);
  CHECK_EQUAL(cube_bricks, m.regions[int(Region::kBrickFlags)].bytes);
  const BoardCapacities* am = find_board("am335x");
  CHECK(am != nullptr);
  CHECK_FALSE(am->colour);
  CHECK_EQUAL(128, am->volume_dim);
  CHECK_EQUAL(0u, make_memory_map(*am).regions[int(Region::kVoxelColour)].bytes);
  CHECK(find_board("no-such-board") == nullptr);
}

TEST(MemMap, EveryBoardFitsItsBudget) {
  for (int i = 0; i < board_count(); ++i) {
    const BoardCapacities& b = board_at(i);
    CHECK(make_memory_map(b).total_bytes <= b.ram_budget_bytes);
  }
  CHECK(static_arena_bytes() >= make_memory_map(build_board()).total_bytes);
}

TEST(MemMap, CarvedRegionsAreAlignedAndDisjoint) {
  CoreBuffers buf;
  CHECK(carve_memory(build_board(), static_arena(), static_arena_bytes(), buf) == Status::kOk);
  const uintptr_t lo = reinterpret_cast<uintptr_t>(static_arena());
  const uintptr_t hi = lo + static_arena_bytes();
  const void* ptrs[] = {buf.voxels.tsdf, buf.voxels.weight, buf.voxels.brick_slot, buf.voxels.brick_flags, buf.voxels.brick_list,
                        buf.depth_frames, buf.ray_norms, buf.raycast_depth, buf.raycast_vertex, buf.points,
                        buf.mesh_scratch.edge_ids};
  for (const void* p : ptrs) {
    const uintptr_t a = reinterpret_cast<uintptr_t>(p);
    CHECK(a >= lo && a < hi);
    CHECK_EQUAL(0u, a % kRegionAlign);
  }
  CHECK(reinterpret_cast<uintptr_t>(buf.voxels.weight) >=
        reinterpret_cast<uintptr_t>(buf.voxels.tsdf) + make_memory_map(build_board()).regions[0].bytes);
  CHECK(carve_memory(build_board(), static_arena(), 1024, buf) == Status::kCapacityExceeded);
}

TEST(MemMap, AcquisitionFramePoolsAreRegionsSizedByTheBoard) {
  for (int i = 0; i < board_count(); ++i) {
    const BoardCapacities& b = board_at(i);
    const MemoryMap m = make_memory_map(b);
    const uint64_t pooled = uint64_t(b.image_width_max) * b.image_height_max * b.sensors_max * kFramePoolSlots;
    CHECK_EQUAL(pooled * 2, m.regions[int(Region::kAcqDepth)].bytes);
    CHECK_EQUAL(pooled * 3, m.regions[int(Region::kAcqColour)].bytes);
    CHECK_EQUAL(pooled * 2, m.regions[int(Region::kAcqAmplitude)].bytes);
    STRCMP_CONTAINS("acquisition pools", m.regions[int(Region::kAcqDepth)].name);
  }
  CoreBuffers buf;
  CHECK(carve_memory(build_board(), static_arena(), static_arena_bytes(), buf) == Status::kOk);
  CHECK_EQUAL(build_board().sensors_max, buf.frame_pools.pools);
  CHECK_EQUAL(kFramePoolSlots, buf.frame_pools.slots);
  const uintptr_t lo = reinterpret_cast<uintptr_t>(static_arena());
  const uintptr_t hi = lo + static_arena_bytes();
  const void* ptrs[] = {buf.frame_pools.depth, buf.frame_pools.colour, buf.frame_pools.amplitude};
  for (const void* p : ptrs) {
    const uintptr_t a = reinterpret_cast<uintptr_t>(p);
    CHECK(a >= lo && a < hi);
    CHECK_EQUAL(0u, a % kRegionAlign);
  }
}
