#include "edgefuse/tsdf/volume.hpp"

#include <cstring>

namespace edgefuse {

Status TsdfVolume::init(const VoxelStorage& storage, int dim, const Vec3f& origin_m, const TsdfParams& params) {
  if (storage.tsdf == nullptr || storage.weight == nullptr || storage.brick_flags == nullptr ||
      storage.brick_list == nullptr || storage.brick_slot == nullptr || storage.pool_bricks < 2)
    return Status::kInvalidArgument;
  if ((storage.colour == nullptr) != (storage.colour_weight == nullptr)) return Status::kInvalidArgument;
  if (dim <= 0 || dim % kBrickSide != 0) return Status::kInvalidArgument;
  if (dim > storage.capacity_dim) return Status::kCapacityExceeded;
  // Voxel indices are 32-bit in the raycast: the pool stays below 2^32 voxels.
  if (uint64_t(storage.pool_bricks) * kBrickVoxels > 0xFFFFFFFFull) return Status::kInvalidArgument;
  if (!(params.voxel_m > 0) || !(params.trunc_m >= params.voxel_m) || !params.weight.valid() ||
      params.weight.rho_m > params.trunc_m || params.max_weight == 0 || !(params.colour_band_m >= 0) ||
      !(params.free_margin_m >= 0) ||
      !origin_m.allFinite())
    return Status::kInvalidArgument;
  s_ = storage;
  dim_ = dim;
  origin_m_ = origin_m;
  params_ = params;
  weight_table_.build(params.weight);
  clear();
  return Status::kOk;
}

void TsdfVolume::reset_slot(uint32_t slot) {
  const std::size_t base = std::size_t(slot) * kBrickVoxels;
  for (int i = 0; i < kBrickVoxels; ++i) s_.tsdf[base + i] = kTsdfUnobserved;
  std::memset(s_.weight + base, 0, kBrickVoxels);
  if (s_.colour != nullptr) {
    std::memset(static_cast<void*>(s_.colour + base), 0, kBrickVoxels * sizeof(Rgb8));
    std::memset(s_.colour_weight + base, 0, kBrickVoxels);
  }
}

void TsdfVolume::clear() {
  if (!initialised()) return;
  // Slots get their voxels reset when handed out (store_brick), so only the index and the empty
  // brick are reset here: clearing costs the index, not the pool.
  std::memset(s_.brick_slot, 0, brick_count() * sizeof(uint32_t));
  reset_slot(0);
  slots_used_ = 1;
  bricks_refused_ = 0;
  std::memset(s_.brick_flags, 0, brick_count());
  if (s_.block_mask != nullptr) std::memset(s_.block_mask, 0, brick_count() * sizeof(uint64_t));
}

std::size_t TsdfVolume::observed_voxels() const {
  std::size_t count = 0;
  const std::size_t bricks = brick_count();
  for (std::size_t b = 0; b < bricks; ++b) {
    if (!(s_.brick_flags[b] & kBrickObserved)) continue;
    const uint8_t* w = s_.weight + brick_base(b);
    for (int i = 0; i < kBrickVoxels; ++i) count += w[i] != 0;
  }
  return count;
}

}  // namespace edgefuse
