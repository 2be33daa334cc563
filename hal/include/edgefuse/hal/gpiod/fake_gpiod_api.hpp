// A fake libgpiod for host tests: one chip with lines; the test queues edge events with kernel
// stamps, makes waits fail with EINTR, or removes the chip (ENODEV). Never blocks.
#pragma once

#include <cerrno>
#include <cstring>
#include <deque>

#include "edgefuse/hal/gpiod/gpiod_api.hpp"

namespace edgefuse::hal {

class FakeGpiodApi final : public GpiodApi {
 public:
  const char* chip_name = "gpiochip0";
  unsigned lines = 32;
  bool chip_present = true;
  bool debounce_in_kernel = false;  //!< true: behave like libgpiod 2 (kernel debounce)
  int wait_eintr = 0;               //!< the next n waits fail with EINTR
  std::deque<GpiodRawEvent> events; //!< pending events on the requested input line
  int output_value = -1;            //!< last level driven on the output line
  int output_writes = 0;
  int requests = 0, releases = 0;
  EdgeSelect requested_edges = EdgeSelect::kRising;
  uint32_t requested_debounce_us = 0;

  //! \param kind edge  \param stamp_ns kernel stamp
  void edge(EdgeKind kind, uint64_t stamp_ns) { events.push_back(GpiodRawEvent{kind, stamp_ns}); }

  Line request_events(const char* chip, unsigned offset, EdgeSelect e, uint32_t debounce_us, const char*) override {
    if (!open(chip, offset)) return nullptr;
    requested_edges = e;
    requested_debounce_us = debounce_us;
    ++requests;
    return &input_;
  }
  Line request_output(const char* chip, unsigned offset, const char*, int value) override {
    if (!open(chip, offset)) return nullptr;
    output_value = value;
    ++requests;
    return &output_;
  }
  void release(Line) override { ++releases; }
  int wait_event(Line, uint32_t) override {
    if (!chip_present) return fail(ENODEV);
    if (wait_eintr > 0) {
      --wait_eintr;
      return fail(EINTR);
    }
    return events.empty() ? 0 : 1;
  }
  int read_event(Line, GpiodRawEvent& e) override {
    if (!chip_present) return fail(ENODEV);
    if (events.empty()) return fail(EAGAIN);
    e = events.front();
    events.pop_front();
    return 0;
  }
  int set_value(Line, int value) override {
    if (!chip_present) return fail(ENODEV);
    output_value = value;
    ++output_writes;
    return 0;
  }
  bool kernel_debounce() const override { return debounce_in_kernel; }

 private:
  bool open(const char* chip, unsigned offset) {
    if (!chip_present || std::strcmp(chip, chip_name) != 0) {
      errno = ENOENT;
      return false;
    }
    if (offset >= lines) {
      errno = EINVAL;
      return false;
    }
    return true;
  }
  static int fail(int e) {
    errno = e;
    return -1;
  }
  int input_ = 0, output_ = 0;
};

}  // namespace edgefuse::hal
