// The truncated signed distance space (paper section 3.1) over caller-provided static storage.
//
// Layout: a cube of dim^3 voxels (dim a multiple of 8, at most the board's index capacity) cut
// into 8^3 bricks. Only bricks that hold a measurement have voxels: they live in a fixed pool of
// pool_bricks slots of 512 contiguous voxels each (so integration and raycasting touch whole cache
// lines and can skip whole bricks), reached through a preallocated index (one slot number per
// brick of the cube). Slot 0 is an empty brick, never written: every brick without its own slot
// points at it, so a reader sees "unobserved" there without a test. Integration gives a brick a
// slot the first time it writes into it; when the pool is full the brick is not stored and the
// refusal is counted (bricks_refused()): the map keeps what it holds and stops growing. Each brick
// of the cube has a flag byte.
//
// A voxel is compact, stored as parallel arrays (structure of arrays):
//   tsdf    int16   distance / trunc, scaled so that +-32767 = +-1 (truncated); -32768 = unobserved
//   weight  uint8   accumulated weight in 1/8 sample units (kWeightUnitsPerSample), capped
//   colour  3 x uint8 RGB + uint8 colour weight   (only when the board enables colour)
//
// Geometry: `origin_m` is the world position of the volume's minimum corner; voxel (i, j, k) has
// its centre at origin_m + (i + 0.5, j + 0.5, k + 0.5) * voxel_m. Frames: the volume is axis-
// aligned in the world frame.
#pragma once

#include <cstddef>
#include <cstdint>

#include "edgefuse/core/image.hpp"
#include "edgefuse/core/status.hpp"
#include "edgefuse/math/pose.hpp"
#include "edgefuse/tsdf/weight.hpp"

namespace edgefuse {

inline constexpr int kBrickSide = 8;
inline constexpr int kBrickVoxels = kBrickSide * kBrickSide * kBrickSide;
inline constexpr int16_t kTsdfMax = 32767;     //!< stored value of a distance >= +trunc
//! Stored distance of a voxel never observed (weight 0). Integration never produces it (samples are
//! clamped to +-kTsdfMax), so readers that need only distances (raycast) test a single array.
inline constexpr int16_t kTsdfUnobserved = -32768;
inline constexpr int kWeightUnitsPerSample = 8;  //!< a full-weight sample adds 8 to the weight

enum BrickFlag : uint8_t {
  kBrickObserved = 1,     //!< some voxel has weight > 0
  kBrickSurface = 2,      //!< some voxel is inside the truncation band (|tsdf| < 1)
  kBrickNearSurface = 4,  //!< this brick or one of its 26 neighbours has kBrickSurface
  kBrickDilated = 8,      //!< kBrickNearSurface already set on the 26 neighbours
  //! Listed for the frame being integrated: set by select_band_bricks, cleared by
  //! finish_integration (integrate.hpp); never set outside an integration.
  kBrickListed = 16,
  //! With kBrickListed: the brick may hold band voxels of this frame (else only its free margin).
  kBrickBand = 32,
  //! The brick needed a pool slot while the pool was full (counted once, until clear()).
  kBrickRefused = 64,
};

//! Views of the static buffers of one volume: the voxel pool holds pool_bricks * 512 voxels, the
//! per-brick arrays (capacity_dim/8)^3 entries.
struct VoxelStorage {
  int16_t* tsdf = nullptr;            //!< pool_bricks * 512
  uint8_t* weight = nullptr;          //!< pool_bricks * 512
  Rgb8* colour = nullptr;             //!< pool_bricks * 512, or null when the board has no colour
  uint8_t* colour_weight = nullptr;   //!< pool_bricks * 512, or null with colour
  uint32_t* brick_slot = nullptr;     //!< (capacity_dim/8)^3: the pool slot of each brick, 0 = none
  uint8_t* brick_flags = nullptr;     //!< (capacity_dim/8)^3
  uint32_t* brick_list = nullptr;     //!< (capacity_dim/8)^3: bricks selected for one update
  //! (capacity_dim/8)^3, optional (null: the raycast bounds its search by whole bricks). Bit
  //! (z/2)*16 + (y/2)*4 + x/2 of a kBrickSurface brick is set when the 2^3 voxels at local
  //! (x, y, z) hold an observed distance <= 0; integration keeps it current (block_mask.hpp).
  uint64_t* block_mask = nullptr;
  int capacity_dim = 0;               //!< voxels per axis the index covers
  uint32_t pool_bricks = 0;           //!< slots in the voxel pool, slot 0 (the empty brick) included
};

//! Default free margin (TsdfParams::free_margin_m): about the radius of a part a localiser
//! places, so that a wrong pose's model points near the surfaces fall into observed free space.
//! Measured on the simulated robot cell (tools/run's cycle, test_robot_cell_e2e; 2 mm voxels):
//! with 16 mm, 1 run in 6 missed an object or came out at 1.3-1.8 mm / 0.7-1.3 deg median; with
//! 64 mm, 6 of 6 found all objects at 0.75-1.21 mm / 0.44-0.60 deg, as with the whole frustum
//! integrated. Cost: about +14 % integration time on bin_rig_a xtion.
inline constexpr float kDefaultFreeMarginM = 0.064f;

struct TsdfParams {
  float voxel_m = 0.01f;       //!< voxel edge length
  float trunc_m = 0.04f;       //!< truncation distance (distance stored as +-1 beyond it)
  WeightParams weight;         //!< eq. (2); see weight.hpp for the defaults
  uint8_t max_weight = 255;    //!< weight cap in 1/8 samples (255: the last ~32 samples count)
  float colour_band_m = 0.0f;  //!< colour is fused only where |d| < colour_band (0: = eps)
  //! Free space integrated in front of each measurement beyond the truncation band (0: the larger
  //! of 2 trunc and kDefaultFreeMarginM); further from any surface it is not touched
  //! (integrate.hpp). The localiser's verification reads it: a pose that puts model points into
  //! observed free space is rejected, while an unobserved point counts as occluded.
  float free_margin_m = 0.0f;

  //! Parameters with the documented defaults for a voxel size and truncation.
  //! \param voxel_m voxel edge in metres  \param trunc_m truncation in metres
  static TsdfParams defaults_for(float voxel_m, float trunc_m) {
    TsdfParams p;
    p.voxel_m = voxel_m;
    p.trunc_m = trunc_m;
    p.weight = WeightParams::defaults_for(trunc_m);
    return p;
  }
};

class TsdfVolume {
 public:
  //! Binds storage and sets the geometry; clears the space.
  //! \param storage static buffers (capacity_dim >= dim)
  //! \param dim voxels per axis, a multiple of 8
  //! \param origin_m world position of the minimum corner
  //! \param params voxel size, truncation, weights
  Status init(const VoxelStorage& storage, int dim, const Vec3f& origin_m, const TsdfParams& params);
  //! Forgets every measurement (weights 0, distances kTsdfUnobserved, flags 0).
  void clear();
  //! Moves the volume without touching voxels (use on an empty space).
  void set_origin(const Vec3f& origin_m) { origin_m_ = origin_m; }

  bool initialised() const { return s_.tsdf != nullptr; }
  bool has_colour() const { return s_.colour != nullptr; }
  int dim() const { return dim_; }
  int bricks_per_axis() const { return dim_ / kBrickSide; }
  std::size_t brick_count() const { return std::size_t(bricks_per_axis()) * bricks_per_axis() * bricks_per_axis(); }
  std::size_t voxel_count() const { return std::size_t(dim_) * dim_ * dim_; }
  //! Slots of the voxel pool (the empty brick included) and how many are in use.
  uint32_t pool_bricks() const { return s_.pool_bricks; }
  uint32_t bricks_in_use() const { return slots_used_ - 1u; }
  //! Bricks that needed a slot while the pool was full, since the last clear() (each counted once).
  uint64_t bricks_refused() const { return bricks_refused_; }
  //! Voxels the pool holds (slot 0 included): the extent of the voxel arrays.
  std::size_t pool_voxels() const { return std::size_t(s_.pool_bricks) * kBrickVoxels; }
  float voxel_m() const { return params_.voxel_m; }
  const Vec3f& origin_m() const { return origin_m_; }
  const TsdfParams& params() const { return params_; }
  const WeightTable& weight_table() const { return weight_table_; }

  //! Index into the voxel arrays of voxel (x, y, z), each in [0, dim); a brick without a slot
  //! gives an index into the empty brick (read only).
  std::size_t index(int x, int y, int z) const {
    const int nb = bricks_per_axis();
    const std::size_t brick = (std::size_t(z >> 3) * nb + std::size_t(y >> 3)) * nb + std::size_t(x >> 3);
    return brick_base(brick) + std::size_t(((z & 7) << 6) | ((y & 7) << 3) | (x & 7));
  }
  //! Index of the first voxel of a brick (0, the empty brick, when it has no slot).
  std::size_t brick_base(std::size_t brick) const { return std::size_t(s_.brick_slot[brick]) * kBrickVoxels; }
  //! True when the brick has voxels of its own.
  bool brick_stored(std::size_t brick) const { return s_.brick_slot[brick] != 0; }
  //! Gives the brick a pool slot, its voxels unobserved, unless it has one; false (and counted)
  //! when the pool is full. Not thread-safe: integration calls it while listing bricks.
  bool store_brick(std::size_t brick) {
    if (s_.brick_slot[brick] != 0) return true;
    if (slots_used_ >= s_.pool_bricks) {
      if (!(s_.brick_flags[brick] & kBrickRefused)) ++bricks_refused_;
      s_.brick_flags[brick] |= kBrickRefused;
      return false;
    }
    s_.brick_slot[brick] = slots_used_;
    reset_slot(slots_used_++);
    return true;
  }
  std::size_t brick_index(int bx, int by, int bz) const {
    const int nb = bricks_per_axis();
    return (std::size_t(bz) * nb + std::size_t(by)) * nb + std::size_t(bx);
  }
  void brick_coords(std::size_t brick, int& bx, int& by, int& bz) const {
    const int nb = bricks_per_axis();
    bx = int(brick % nb);
    by = int((brick / nb) % nb);
    bz = int(brick / (std::size_t(nb) * nb));
  }
  //! World position of the centre of voxel (x, y, z).
  Vec3f voxel_centre(int x, int y, int z) const {
    return origin_m_ + (Vec3f(float(x), float(y), float(z)) + Vec3f::Constant(0.5f)) * params_.voxel_m;
  }

  int16_t* tsdf() { return s_.tsdf; }
  const int16_t* tsdf() const { return s_.tsdf; }
  uint8_t* weight() { return s_.weight; }
  const uint8_t* weight() const { return s_.weight; }
  Rgb8* colour() { return s_.colour; }
  const Rgb8* colour() const { return s_.colour; }
  uint8_t* colour_weight() { return s_.colour_weight; }
  const uint8_t* colour_weight() const { return s_.colour_weight; }
  //! The brick index: the pool slot of each brick of the cube (0: the empty brick).
  const uint32_t* brick_slots() const { return s_.brick_slot; }
  uint8_t* brick_flags() { return s_.brick_flags; }
  const uint8_t* brick_flags() const { return s_.brick_flags; }
  uint32_t* brick_list() { return s_.brick_list; }
  uint64_t* block_mask() { return s_.block_mask; }
  const uint64_t* block_mask() const { return s_.block_mask; }

  //! Number of voxels with weight > 0.
  std::size_t observed_voxels() const;

 private:
  void reset_slot(uint32_t slot);

  VoxelStorage s_;
  uint32_t slots_used_ = 1;  // slot 0 is the empty brick
  uint64_t bricks_refused_ = 0;
  int dim_ = 0;
  Vec3f origin_m_ = Vec3f::Zero();
  TsdfParams params_;
  WeightTable weight_table_;
};

}  // namespace edgefuse
