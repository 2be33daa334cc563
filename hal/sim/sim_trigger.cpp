#include "edgefuse/hal/sim/sim_trigger.hpp"

#include <chrono>

namespace edgefuse::hal {

void SimTriggerLine::push(const TriggerEdge& edge) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (count_ == kCapacity) {
      head_ = (head_ + 1) % kCapacity;
      --count_;
      ++overflows_;
    }
    ring_[(head_ + count_) % kCapacity] = edge;
    ++count_;
  }
  cv_.notify_one();
}

bool SimTriggerLine::pop(TriggerEdge& edge, uint32_t timeout_ms) {
  std::unique_lock<std::mutex> lock(mutex_);
  if (!cv_.wait_for(lock, std::chrono::milliseconds(timeout_ms), [this] { return count_ > 0; })) return false;
  edge = ring_[head_];
  head_ = (head_ + 1) % kCapacity;
  --count_;
  return true;
}

HalStatus SimTriggerOutput::set(bool high) {
  if (!started_) return HalStatus::kNotStarted;
  if (high != level_) {
    TriggerEdge e;
    e.kind = high ? EdgeKind::kRising : EdgeKind::kFalling;
    e.stamp_us = clock_.now_us();
    line_.push(e);
    level_ = high;
  }
  return HalStatus::kOk;
}

HalStatus SimTriggerOutput::pulse(uint32_t width_us) {
  HalStatus s = set(true);
  if (s != HalStatus::kOk) return s;
  clock_.sleep_us(width_us);
  return set(false);
}

HalStatus SimTriggerInput::start(EdgeSelect edges, uint32_t debounce_us) {
  select_ = edges;
  debounce_us_ = debounce_us;
  next_us_ = clock_.now_us() + period_us_;
  have_last_ = false;
  sequence_ = 0;
  started_ = true;
  return HalStatus::kOk;
}

// A reader that falls behind a free-running line finds at most kQueuedEdges edges waiting, as the
// kernel's line-event buffer of a GPIO holds 16: older edges are lost (counted, and the sequence
// number jumps over them), not delivered late in a burst.
void SimTriggerInput::skip_lost_edges(uint64_t now_us) {
  if (now_us < next_us_ + kQueuedEdges * uint64_t(period_us_)) return;
  const uint64_t lost = (now_us - next_us_) / period_us_ + 1 - kQueuedEdges;
  next_us_ += lost * period_us_;
  sequence_ += uint32_t(lost);
  lost_ += uint32_t(lost);
}

bool SimTriggerInput::accept(const TriggerEdge& e) const {
  if (select_ == EdgeSelect::kRising && e.kind != EdgeKind::kRising) return false;
  if (select_ == EdgeSelect::kFalling && e.kind != EdgeKind::kFalling) return false;
  return true;
}

HalStatus SimTriggerInput::wait_edge(TriggerEdge& edge, uint32_t timeout_ms) {
  if (!started_) return HalStatus::kNotStarted;
  const uint64_t deadline = clock_.now_us() + uint64_t(timeout_ms) * 1000u;
  for (;;) {
    TriggerEdge e;
    if (line_ != nullptr) {
      const uint64_t now = clock_.now_us();
      if (now >= deadline && timeout_ms > 0) return HalStatus::kTimeout;
      if (!line_->pop(e, uint32_t((deadline - now + 999) / 1000))) return HalStatus::kTimeout;
    } else {
      if (period_us_ == 0) return HalStatus::kTimeout;
      const uint64_t now = clock_.now_us();
      if (next_us_ > deadline) {
        if (deadline > now) clock_.sleep_us(deadline - now);
        return HalStatus::kTimeout;
      }
      if (next_us_ > now) clock_.sleep_us(next_us_ - now);
      skip_lost_edges(now);
      e.kind = EdgeKind::kRising;
      e.stamp_us = next_us_;
      next_us_ += period_us_;
    }
    if (!accept(e)) continue;
    if (have_last_ && debounce_us_ > 0 && e.stamp_us - last_accepted_us_ < debounce_us_) {
      ++debounced_;
      continue;
    }
    have_last_ = true;
    last_accepted_us_ = e.stamp_us;
    edge = e;
    edge.sequence = sequence_++;
    return HalStatus::kOk;
  }
}

}  // namespace edgefuse::hal
