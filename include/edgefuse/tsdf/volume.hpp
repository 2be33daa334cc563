// The truncated signed distance space (paper section 3.1) over caller-provided static storage.
//
// Layout: a cube of dim^3 voxels (dim a multiple of 8, at most the board's capacity) kept in
// 8^3 bricks, brick-major: the 512 voxels of a brick are contiguous, so integration and
// raycasting touch whole cache lines and can skip whole bricks. Each brick has a flag byte.
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
};

//! Views of the static buffers of one volume; sizes are for capacity_dim^3 voxels.
struct VoxelStorage {
  int16_t* tsdf = nullptr;            //!< capacity_dim^3
  uint8_t* weight = nullptr;          //!< capacity_dim^3
  Rgb8* colour = nullptr;             //!< capacity_dim^3, or null when the board has no colour
  uint8_t* colour_weight = nullptr;   //!< capacity_dim^3, or null with colour
  uint8_t* brick_flags = nullptr;     //!< (capacity_dim/8)^3
  uint32_t* brick_list = nullptr;     //!< (capacity_dim/8)^3: bricks selected for one update
  //! (capacity_dim/8)^3, optional (null: the raycast bounds its search by whole bricks). Bit
  //! (z/2)*16 + (y/2)*4 + x/2 of a kBrickSurface brick is set when the 2^3 voxels at local
  //! (x, y, z) hold an observed distance <= 0; integration keeps it current (block_mask.hpp).
  uint64_t* block_mask = nullptr;
  int capacity_dim = 0;               //!< voxels per axis the buffers hold
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
  float voxel_m() const { return params_.voxel_m; }
  const Vec3f& origin_m() const { return origin_m_; }
  const TsdfParams& params() const { return params_; }
  const WeightTable& weight_table() const { return weight_table_; }

  //! Linear index of voxel (x, y, z), each in [0, dim).
  std::size_t index(int x, int y, int z) const {
    const int nb = bricks_per_axis();
    const std::size_t brick = (std::size_t(z >> 3) * nb + std::size_t(y >> 3)) * nb + std::size_t(x >> 3);
    return brick * kBrickVoxels + std::size_t(((z & 7) << 6) | ((y & 7) << 3) | (x & 7));
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
  uint8_t* brick_flags() { return s_.brick_flags; }
  const uint8_t* brick_flags() const { return s_.brick_flags; }
  uint32_t* brick_list() { return s_.brick_list; }
  uint64_t* block_mask() { return s_.block_mask; }
  const uint64_t* block_mask() const { return s_.block_mask; }

  //! Number of voxels with weight > 0.
  std::size_t observed_voxels() const;

 private:
  VoxelStorage s_;
  int dim_ = 0;
  Vec3f origin_m_ = Vec3f::Zero();
  TsdfParams params_;
  WeightTable weight_table_;
};

}  // namespace edgefuse
