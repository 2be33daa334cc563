// What a board can hold: the sizes of every static buffer derive from these numbers.
// The values come from board/<name>/board.toml ([capacity] and [memory]) at build time.
#pragma once

#include <cstdint>

namespace edgefuse {

struct BoardCapacities {
  const char* name;            //!< board folder name
  int volume_dim;              //!< voxels per axis (multiple of 8)
  bool colour;                 //!< voxels carry RGB + colour weight
  int image_width_max;         //!< largest depth image per sensor, pixels
  int image_height_max;
  int sensors_max;             //!< sensors streaming at once
  uint32_t points_max;         //!< largest point set (extraction / fused cloud)
  int objects_max;             //!< most objects in one localisation result
  uint64_t ram_budget_bytes;   //!< what the static memory map may use
  bool fixed_point;            //!< the board's default numeric build
};

}  // namespace edgefuse
