// The acquisition pools' share of the static memory map: how many frames / profiles each pool
// holds and the views of the pools once the arena is carved. The memory map (memmap.hpp) sizes
// and carves them; the HAL's acquisition runtime (edgefuse/hal/acquisition/frame_pool.hpp) binds
// its channels to them without depending on the rest of the map (TSDF, tracking, localisation).
#pragma once

#include <cstddef>
#include <cstdint>

#include "edgefuse/core/image.hpp"

namespace edgefuse {

//! Frames in each sensor's acquisition pool: the device fills one, a stereo pairer holds up to
//! three of a stream, processing one more, and one is in flight.
inline constexpr int kFramePoolSlots = 6;
//! Profiles in the line scanner's pool: those that wait between two main-loop ticks of the
//! firmware (15, the most the channel's 16-entry rings hold: 150 ms at 100 Hz), each of up to the
//! board's widest image in beams (a profile's ray table takes a sensor slot of image_width_max x
//! image_height_max entries, so no scanner the board can place has more beams).
inline constexpr int kProfilePoolSlots = 15;

//! The acquisition frame pools: `pools` pools (one per sensor) of `slots` frames of up to
//! `pixels_per_slot` pixels each, slot after slot, pool after pool.
struct FramePoolBuffers {
  uint16_t* depth = nullptr;
  Rgb8* colour = nullptr;
  uint16_t* amplitude = nullptr;
  std::size_t pixels_per_slot = 0;
  int slots = 0;
  int pools = 0;
};

//! The line scanner's profile pool: `slots` profiles of up to `beams_max` ranges each, slot after
//! slot.
struct ProfilePoolBuffers {
  float* ranges_m = nullptr;
  int beams_max = 0;
  int slots = 0;
};

}  // namespace edgefuse
