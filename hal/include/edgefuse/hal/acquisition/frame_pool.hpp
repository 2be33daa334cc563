// Binds a camera's FrameChannel to its pool in the board's static memory map (the regions
// "acquisition pools: depth / colour / amplitude" of include/edgefuse/memory/memmap.hpp), so the
// pools are sized by the board, listed by `edgefuse memmap` and counted by the compile-time RAM
// budget check. FrameChannelStorage (a .bss array sized by a template) remains for tests and
// tools that need no arena. The line scanner's profile pool is a region too ("acquisition pools:
// line profiles", bind_profile_pool).
#pragma once

#include <cstddef>

#include "edgefuse/memory/acquisition_pools.hpp"
#include "edgefuse/hal/acquisition/frame_channel.hpp"

namespace edgefuse::hal {

//! The DepthFrame views of one pool (small; the pixels live in the memory map).
struct FramePoolViews {
  DepthFrame frames[kFramePoolSlots];
};

//! Points `views` at pool `pool` of `pools` and initialises `channel` with them (start-up).
//! \param pools the carved memory map's frame pools  \param pool which pool (0 .. pools.pools-1)
//! \param views caller storage for the frame views  \param channel the channel to initialise
//! \param counters its counters  \return false when the pool does not exist or is unsized
inline bool bind_frame_pool(const FramePoolBuffers& pools, int pool, FramePoolViews& views, FrameChannel& channel,
                            AcquisitionCounters& counters) {
  if (pool < 0 || pool >= pools.pools || pools.slots != kFramePoolSlots || pools.depth == nullptr ||
      pools.colour == nullptr || pools.amplitude == nullptr || pools.pixels_per_slot == 0)
    return false;
  for (int i = 0; i < kFramePoolSlots; ++i) {
    const std::size_t at = (std::size_t(pool) * std::size_t(kFramePoolSlots) + std::size_t(i)) * pools.pixels_per_slot;
    DepthFrame f;
    f.depth = pools.depth + at;
    f.colour = pools.colour + at;
    f.amplitude = pools.amplitude + at;
    f.capacity_pixels = int(pools.pixels_per_slot);
    views.frames[i] = f;
  }
  return channel.init(views.frames, kFramePoolSlots, &counters);
}

//! The LineProfile views of the line scanner's profile pool.
struct ProfilePoolViews {
  LineProfile profiles[kProfilePoolSlots];
};
static_assert(kProfilePoolSlots >= 3 && kProfilePoolSlots <= ProfileChannel::kMaxSlots,
              "the profile pool must fit the channel's rings");

//! Points `views` at the memory map's profile pool and initialises `channel` with them (start-up,
//! and again to empty the pool while its thread is stopped).
//! \param pool the carved memory map's profile pool  \param beams the scanner's beams per profile
//! \param views caller storage for the profile views  \param channel the channel to initialise
//! \param counters its counters  \return false when the pool is missing or its profiles are too short
inline bool bind_profile_pool(const ProfilePoolBuffers& pool, int beams, ProfilePoolViews& views,
                              ProfileChannel& channel, AcquisitionCounters& counters) {
  if (pool.ranges_m == nullptr || pool.slots != kProfilePoolSlots || beams <= 0 || beams > pool.beams_max)
    return false;
  for (int i = 0; i < kProfilePoolSlots; ++i) {
    LineProfile p;
    p.ranges_m = pool.ranges_m + std::size_t(i) * std::size_t(pool.beams_max);
    p.capacity_beams = pool.beams_max;
    views.profiles[i] = p;
  }
  return channel.init(views.profiles, kProfilePoolSlots, &counters);
}

}  // namespace edgefuse::hal
