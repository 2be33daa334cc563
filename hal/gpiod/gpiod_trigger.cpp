#include "edgefuse/hal/gpiod/gpiod_trigger.hpp"

#include <cerrno>

namespace edgefuse::hal {

namespace {
HalStatus from_errno(int e) {
  return (e == ENODEV || e == ENOENT || e == ENXIO) ? HalStatus::kNoDevice : HalStatus::kIoError;
}
}  // namespace

HalStatus GpiodTriggerInput::start(EdgeSelect edges, uint32_t debounce_us) {
  stop();
  line_ = api_.request_events(config_.chip, config_.offset, edges, debounce_us, config_.consumer);
  if (!line_) return from_errno(errno);
  // Debounce in software unless the kernel does it.
  debounce_us_ = api_.kernel_debounce() ? 0 : debounce_us;
  have_last_ = false;
  sequence_ = 0;
  return HalStatus::kOk;
}

void GpiodTriggerInput::stop() {
  if (line_) api_.release(line_);
  line_ = nullptr;
}

HalStatus GpiodTriggerInput::wait_edge(TriggerEdge& edge, uint32_t timeout_ms) {
  if (!line_) return HalStatus::kNotStarted;
  const uint64_t deadline_us = clock_.now_us() + uint64_t(timeout_ms) * 1000u;
  for (;;) {
    const uint64_t now = clock_.now_us();
    const uint32_t left_ms = deadline_us > now ? uint32_t((deadline_us - now + 999) / 1000) : 0;
    const int r = api_.wait_event(line_, left_ms);
    if (r == 0) return HalStatus::kTimeout;
    if (r < 0) {
      if (errno == EINTR) continue;  // a signal: wait for the rest of the time
      return from_errno(errno);
    }
    GpiodRawEvent ev;
    if (api_.read_event(line_, ev) < 0) {
      if (errno == EINTR || errno == EAGAIN) continue;
      return from_errno(errno);
    }
    const uint64_t stamp_us = ev.stamp_ns / 1000u;
    if (have_last_ && debounce_us_ > 0 && stamp_us - last_us_ < debounce_us_) {
      ++debounced_;  // a bounce of the last accepted edge
      continue;
    }
    have_last_ = true;
    last_us_ = stamp_us;
    edge.kind = ev.kind;
    edge.stamp_us = stamp_us;
    edge.sequence = sequence_++;
    return HalStatus::kOk;
  }
}

HalStatus GpiodTriggerOutput::start() {
  stop();
  line_ = api_.request_output(config_.chip, config_.offset, config_.consumer, 0);
  return line_ ? HalStatus::kOk : from_errno(errno);
}

void GpiodTriggerOutput::stop() {
  if (line_) api_.release(line_);
  line_ = nullptr;
}

HalStatus GpiodTriggerOutput::set(bool high) {
  if (!line_) return HalStatus::kNotStarted;
  return api_.set_value(line_, high ? 1 : 0) == 0 ? HalStatus::kOk : from_errno(errno);
}

HalStatus GpiodTriggerOutput::pulse(uint32_t width_us) {
  HalStatus s = set(true);
  if (s != HalStatus::kOk) return s;
  clock_.sleep_us(width_us);
  return set(false);
}

}  // namespace edgefuse::hal
