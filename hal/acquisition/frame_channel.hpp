// Hands frames from a device thread to processing without copying, locking or allocating.
//
// A fixed pool of preallocated frames (caller storage) circulates through two SPSC rings: `ready`
// (device -> processing) and `free` (processing -> device). The device always owns one slot that it
// fills; publish() swaps it for a free slot. Newest-frame policy: processing takes the newest ready
// frame and returns the older ones unread (dropped_stale); if processing holds every other slot,
// the device overwrites its own slot (dropped_overrun) until a slot comes back. Processing may
// hold up to slots - 2 frames at once (a pairer holds two per stream).
#pragma once

#include <cstdint>

#include "edgefuse/hal/depth_frame.hpp"
#include "hal/acquisition/acquisition_counters.hpp"
#include "hal/acquisition/spsc_ring.hpp"

namespace edgefuse::hal {

class FrameChannel {
 public:
  static constexpr int kMaxSlots = 15;  //!< fits the 16-entry rings

  //! \param slots frames pointing at caller storage, all with the same capacity (start-up)
  //! \param count number of slots, 3..kMaxSlots  \param counters where drops are counted
  //! \return false when count is out of range
  bool init(DepthFrame* slots, int count, AcquisitionCounters* counters);

  // --- device thread ---------------------------------------------------------------------
  //! The slot the device fills next.
  DepthFrame& producer_frame() { return slots_[producer_]; }
  //! Hands producer_frame() to processing (or overwrites it next time when no slot is free).
  void publish();

  // --- processing thread -----------------------------------------------------------------
  //! The newest ready frame (held until release()), or null when none arrived. Older ready
  //! frames are returned to the device unread.
  const DepthFrame* acquire_newest();
  //! The ready frame whose stamp is nearest to stamp_us (others returned), or null.
  //! \param stamp_us the target stamp
  const DepthFrame* acquire_nearest(uint64_t stamp_us);
  //! Returns a frame taken by acquire_*().
  //! \param frame the frame
  void release(const DepthFrame* frame);

 private:
  DepthFrame* slots_ = nullptr;
  int count_ = 0;
  AcquisitionCounters* counters_ = nullptr;
  uint8_t producer_ = 0;
  SpscRing<uint8_t, 16> ready_;
  SpscRing<uint8_t, 16> free_;
};

//! Static storage of a channel: Slots frames of up to Pixels pixels (put it in .bss).
template <int Pixels, int Slots>
struct FrameChannelStorage {
  DepthFrameStorage<Pixels> storage[Slots];
  DepthFrame frames[Slots];
  //! Points the frames at the storage and initialises `channel` with them.
  //! \param channel the channel  \param counters its counters
  bool bind(FrameChannel& channel, AcquisitionCounters& counters) {
    for (int i = 0; i < Slots; ++i) frames[i] = storage[i].frame();
    return channel.init(frames, Slots, &counters);
  }
};

}  // namespace edgefuse::hal
