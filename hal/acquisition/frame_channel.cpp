#include "hal/acquisition/frame_channel.hpp"

namespace edgefuse::hal {

bool FrameChannel::init(DepthFrame* slots, int count, AcquisitionCounters* counters) {
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

void FrameChannel::publish() {
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

const DepthFrame* FrameChannel::acquire_newest() {
  uint8_t idx, newest = 0xff;
  while (ready_.pop(idx)) {
    if (newest != 0xff) {
      free_.push(newest);
      counters_->dropped_stale.fetch_add(1, std::memory_order_relaxed);
    }
    newest = idx;
  }
  return newest == 0xff ? nullptr : &slots_[newest];
}

const DepthFrame* FrameChannel::acquire_nearest(uint64_t stamp_us) {
  uint8_t idx, best = 0xff;
  uint64_t best_dt = 0;
  while (ready_.pop(idx)) {
    const uint64_t s = slots_[idx].stamp_us;
    const uint64_t dt = s > stamp_us ? s - stamp_us : stamp_us - s;
    if (best == 0xff || dt < best_dt) {
      if (best != 0xff) {
        free_.push(best);
        counters_->dropped_stale.fetch_add(1, std::memory_order_relaxed);
      }
      best = idx;
      best_dt = dt;
    } else {
      free_.push(idx);
      counters_->dropped_stale.fetch_add(1, std::memory_order_relaxed);
    }
  }
  return best == 0xff ? nullptr : &slots_[best];
}

void FrameChannel::release(const DepthFrame* frame) {
  if (frame == nullptr) return;
  free_.push(uint8_t(frame - slots_));
}

}  // namespace edgefuse::hal
