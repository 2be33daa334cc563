// Binds a camera's FrameChannel to its pool in the board's static memory map (the regions
// "acquisition pools: depth / colour / amplitude" of include/edgefuse/memory/memmap.hpp), so the
// pools are sized by the board, listed by `edgefuse memmap` and counted by the compile-time RAM
// budget check. FrameChannelStorage (a .bss array sized by a template) remains for tests and
// tools that need no arena.
#pragma once

#include "edgefuse/memory/memmap.hpp"
#include "hal/acquisition/frame_channel.hpp"

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

}  // namespace edgefuse::hal
