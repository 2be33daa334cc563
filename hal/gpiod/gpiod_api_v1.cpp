// libgpiod 1.6 behind GpiodApi (the only file that includes gpiod.h).
#include <gpiod.h>

#include <cerrno>
#include <ctime>

#include "edgefuse/hal/gpiod/gpiod_api.hpp"

namespace edgefuse::hal {

namespace {

class LibgpiodV1 final : public GpiodApi {
 public:
  Line request_events(const char* chip_name, unsigned offset, EdgeSelect edges, uint32_t,
                      const char* consumer) override {
    gpiod_line* line = open_line(chip_name, offset);
    if (!line) return nullptr;
    int r;
    switch (edges) {
      case EdgeSelect::kRising: r = gpiod_line_request_rising_edge_events(line, consumer); break;
      case EdgeSelect::kFalling: r = gpiod_line_request_falling_edge_events(line, consumer); break;
      default: r = gpiod_line_request_both_edges_events(line, consumer); break;
    }
    if (r < 0) return close_failed(line);
    return line;
  }
  Line request_output(const char* chip_name, unsigned offset, const char* consumer, int value) override {
    gpiod_line* line = open_line(chip_name, offset);
    if (!line) return nullptr;
    if (gpiod_line_request_output(line, consumer, value) < 0) return close_failed(line);
    return line;
  }
  void release(Line l) override {
    auto* line = static_cast<gpiod_line*>(l);
    gpiod_chip* chip = gpiod_line_get_chip(line);
    gpiod_line_release(line);
    gpiod_chip_close(chip);
  }
  int wait_event(Line l, uint32_t timeout_ms) override {
    timespec ts{};
    ts.tv_sec = time_t(timeout_ms / 1000u);
    ts.tv_nsec = long(timeout_ms % 1000u) * 1000000L;
    return gpiod_line_event_wait(static_cast<gpiod_line*>(l), &ts);
  }
  int read_event(Line l, GpiodRawEvent& event) override {
    gpiod_line_event ev{};
    if (gpiod_line_event_read(static_cast<gpiod_line*>(l), &ev) < 0) return -1;
    event.kind = ev.event_type == GPIOD_LINE_EVENT_RISING_EDGE ? EdgeKind::kRising : EdgeKind::kFalling;
    event.stamp_ns = uint64_t(ev.ts.tv_sec) * 1000000000ull + uint64_t(ev.ts.tv_nsec);
    return 0;
  }
  int set_value(Line l, int value) override { return gpiod_line_set_value(static_cast<gpiod_line*>(l), value); }
  bool kernel_debounce() const override { return false; }  // the v1 uAPI has no debounce

 private:
  static gpiod_line* open_line(const char* chip_name, unsigned offset) {
    gpiod_chip* chip = gpiod_chip_open_lookup(chip_name);
    if (!chip) return nullptr;
    gpiod_line* line = gpiod_chip_get_line(chip, offset);
    if (!line) {
      const int e = errno;
      gpiod_chip_close(chip);
      errno = e;
    }
    return line;
  }
  static Line close_failed(gpiod_line* line) {
    const int e = errno;
    gpiod_chip_close(gpiod_line_get_chip(line));
    errno = e;
    return nullptr;
  }
};

}  // namespace

GpiodApi* libgpiod_api() {
  static LibgpiodV1 api;
  return &api;
}

}  // namespace edgefuse::hal
