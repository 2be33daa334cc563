// What a board can hold: the sizes of every static buffer derive from these numbers.
// The values come from board/<name>/board.toml ([capacity] and [memory]) at build time.
#pragma once

#include <cstdint>

namespace edgefuse {

struct BoardCapacities {
  const char* name;            //!< board folder name
  int volume_dim;              //!< voxels per axis the space's index covers (multiple of 8)
  uint32_t pool_bricks;        //!< 8^3-voxel bricks the voxel pool holds (the empty brick included)
  bool colour;                 //!< voxels carry RGB + colour weight
  int image_width_max;         //!< largest depth image per sensor, pixels
  int image_height_max;
  int sensors_max;             //!< sensors streaming at once
  uint32_t points_max;         //!< largest point set (extraction / fused cloud)
  int objects_max;             //!< most objects in one localisation result
  uint64_t ram_budget_bytes;   //!< what the static memory map may use
  bool fixed_point;            //!< the board's default numeric build
  // localisation
  int models_max;              //!< object models loaded at start-up
  uint32_t model_points_max;   //!< dense surface samples per model (refinement, verification)
  uint32_t ppf_points_max;     //!< sparse samples per model (point pair feature table: n(n-1) entries)
  uint32_t scene_points_max;   //!< scene points the localiser holds (fused surface or input cloud)
  uint32_t hypotheses_max;     //!< pose candidates (vote peaks) per model
};

}  // namespace edgefuse
