// Hands items (depth frames, line profiles) from a device thread to processing without copying,
// locking or allocating.
//
// A fixed pool of preallocated items (caller storage) circulates through two SPSC rings: `ready`
// (device -> processing) and `free` (processing -> device). The device always owns one slot that it
// fills; publish() swaps it for a free slot. Newest-item policy: processing takes the newest ready
// item and returns the older ones unread (dropped_stale); if processing holds every other slot,
// the device overwrites its own slot (dropped_overrun) until a slot comes back. Processing may
// hold up to slots - 2 items at once (a pairer holds up to three per stream).
#pragma once

#include <cstdint>

#include "edgefuse/hal/depth_frame.hpp"
#include "edgefuse/hal/line_scanner.hpp"
#include "edgefuse/hal/acquisition/acquisition_counters.hpp"
#include "edgefuse/hal/acquisition/spsc_ring.hpp"

namespace edgefuse::hal {

//! Item: any type with a uint64_t stamp_us (DepthFrame, LineProfile).
template <class Item>
class PoolChannel {
 public:
  static constexpr int kMaxSlots = 15;  //!< fits the 16-entry rings

  //! \param slots items pointing at caller storage (start-up)  \param count number of slots,
  //! 3..kMaxSlots  \param counters where drops are counted
  //! \return false when count is out of range
  bool init(Item* slots, int count, AcquisitionCounters* counters) {
    if (slots == nullptr || count < 3 || count > kMaxSlots || counters == nullptr) return false;
    slots_ = slots;
    count_ = count;
    counters_ = counters;
    producer_ = 0;
    uint8_t dummy;
    while (ready_.pop(dummy)) {
    }
    while (free_.pop(dummy)) {
    }
    for (int i = 1; i < count; ++i) free_.push(uint8_t(i));
    return true;
  }

  // --- device thread ---------------------------------------------------------------------
  //! The slot the device fills next.
  Item& producer_frame() { return slots_[producer_]; }
  //! Hands producer_frame() to processing (or overwrites it next time when no slot is free).
  void publish() {
    uint8_t next;
    if (!free_.pop(next)) {
      counters_->dropped_overrun.fetch_add(1, std::memory_order_relaxed);
      return;
    }
    ready_.push(producer_);  // never full: the ring holds more entries than there are slots
    counters_->published.fetch_add(1, std::memory_order_relaxed);
    counters_->last_stamp_us.store(slots_[producer_].stamp_us, std::memory_order_relaxed);
    producer_ = next;
  }

  // --- processing thread -----------------------------------------------------------------
  //! The newest ready item (held until release()), or null when none arrived. Older ready
  //! items are returned to the device unread.
  const Item* acquire_newest() {
    uint8_t idx, newest = 0xff;
    while (ready_.pop(idx)) {
      if (newest != 0xff) drop(newest);
      newest = idx;
    }
    return newest == 0xff ? nullptr : &slots_[newest];
  }
  //! The ready item whose stamp is nearest to stamp_us (others returned), or null.
  //! \param stamp_us the target stamp
  const Item* acquire_nearest(uint64_t stamp_us) {
    uint8_t idx, best = 0xff;
    uint64_t best_dt = 0;
    while (ready_.pop(idx)) {
      const uint64_t s = slots_[idx].stamp_us;
      const uint64_t dt = s > stamp_us ? s - stamp_us : stamp_us - s;
      if (best == 0xff || dt < best_dt) {
        if (best != 0xff) drop(best);
        best = idx;
        best_dt = dt;
      } else {
        drop(idx);
      }
    }
    return best == 0xff ? nullptr : &slots_[best];
  }
  //! Every ready item in order, oldest first, through `fn(const Item&)` (line profiles: none may
  //! be skipped); each is returned to the device after the call.
  //! \param fn called per item
  template <class Fn>
  int drain(Fn&& fn) {
    uint8_t idx;
    int n = 0;
    while (ready_.pop(idx)) {
      fn(static_cast<const Item&>(slots_[idx]));
      free_.push(idx);
      ++n;
    }
    return n;
  }
  //! Returns an item taken by acquire_*().
  //! \param item the item
  void release(const Item* item) {
    if (item == nullptr) return;
    free_.push(uint8_t(item - slots_));
  }

 private:
  void drop(uint8_t idx) {
    free_.push(idx);
    counters_->dropped_stale.fetch_add(1, std::memory_order_relaxed);
  }

  Item* slots_ = nullptr;
  int count_ = 0;
  AcquisitionCounters* counters_ = nullptr;
  uint8_t producer_ = 0;
  SpscRing<uint8_t, 16> ready_;
  SpscRing<uint8_t, 16> free_;
};

using FrameChannel = PoolChannel<DepthFrame>;
using ProfileChannel = PoolChannel<LineProfile>;

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

//! Static storage of a profile channel: Slots profiles of up to Beams beams.
template <int Beams, int Slots>
struct ProfileChannelStorage {
  float ranges_m[Slots][Beams];
  LineProfile profiles[Slots];
  //! \param channel the channel  \param counters its counters
  bool bind(ProfileChannel& channel, AcquisitionCounters& counters) {
    for (int i = 0; i < Slots; ++i) {
      profiles[i] = LineProfile{};
      profiles[i].ranges_m = ranges_m[i];
      profiles[i].capacity_beams = Beams;
    }
    return channel.init(profiles, Slots, &counters);
  }
};

}  // namespace edgefuse::hal
