#include "edgefuse/hal/acquisition/frame_pairer.hpp"

namespace edgefuse::hal {

bool FramePairer::poll(FramePair& pair) {
  if (const DepthFrame* na = a_.acquire_newest()) {
    if (held_a_) {
      a_.release(held_a_);
      ++unpaired_a_;
    }
    held_a_ = na;
  }
  const DepthFrame* nb = held_a_ ? b_.acquire_nearest(held_a_->stamp_us) : b_.acquire_newest();
  if (nb) {
    if (held_b_ && held_a_ && diff(held_b_->stamp_us, held_a_->stamp_us) <= diff(nb->stamp_us, held_a_->stamp_us)) {
      b_.release(nb);  // the one already held is nearer
      ++unpaired_b_;
    } else {
      if (held_b_) {
        b_.release(held_b_);
        ++unpaired_b_;
      }
      held_b_ = nb;
    }
  }
  if (!held_a_ || !held_b_) return false;
  const uint64_t ta = held_a_->stamp_us, tb = held_b_->stamp_us;
  if (diff(ta, tb) <= window_us_) {
    pair.a = held_a_;
    pair.b = held_b_;
    held_a_ = held_b_ = nullptr;
    ++pairs_;
    return true;
  }
  if (ta < tb) {
    a_.release(held_a_);
    held_a_ = nullptr;
    ++unpaired_a_;
  } else {
    b_.release(held_b_);
    held_b_ = nullptr;
    ++unpaired_b_;
  }
  return false;
}

void FramePairer::release(FramePair& pair) {
  a_.release(pair.a);
  b_.release(pair.b);
  pair = FramePair{};
}

void FramePairer::reset() {
  a_.release(held_a_);
  b_.release(held_b_);
  held_a_ = held_b_ = nullptr;
}

}  // namespace edgefuse::hal
