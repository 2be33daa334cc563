// libgpiod 2.x behind GpiodApi (the only file that includes a libgpiod 2 gpiod.h). Selected at
// configure time when the found libgpiod is version 2 or later (hal/CMakeLists.txt); Debian
// bookworm ships 1.6, so on this project's machines this file is only compile-checked against the
// documented 2.x declarations (hal/gpiod/v2_check/gpiod.h) and has never run on real hardware.
//
// What differs from 1.6 (and stays here): chips open by path only (names, numbers and labels are
// resolved below), lines are requested through settings/line-config/request-config objects,
// events arrive through an edge-event buffer, stamps are nanoseconds (CLOCK_MONOTONIC asked for
// explicitly), output values are an enum, and the kernel debounces (Linux >= 5.10).
#include <gpiod.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <new>

#include "edgefuse/hal/gpiod/gpiod_api.hpp"

namespace edgefuse::hal {

namespace {

constexpr unsigned kMaxChips = 64;  // /dev/gpiochip0..63 searched for a label

// One requested line: its chip, request, offset and (inputs) a one-event buffer. Allocated at
// request time (start-up or reopen), never per event.
struct V2Line {
  gpiod_chip* chip = nullptr;
  gpiod_line_request* request = nullptr;
  gpiod_edge_event_buffer* buffer = nullptr;
  unsigned offset = 0;
};

// "gpiochipN", "N", "/dev/gpiochipN" or a chip label -> an open chip (v2 opens by path only).
gpiod_chip* open_chip(const char* desc) {
  char path[64];
  if (desc == nullptr || desc[0] == 0) {
    errno = EINVAL;
    return nullptr;
  }
  if (desc[0] == '/') return gpiod_chip_open(desc);
  char* end = nullptr;
  const unsigned long n = std::strtoul(desc, &end, 10);
  if (end != desc && *end == 0) {
    std::snprintf(path, sizeof(path), "/dev/gpiochip%lu", n);
    return gpiod_chip_open(path);
  }
  if (std::strncmp(desc, "gpiochip", 8) == 0) {
    std::snprintf(path, sizeof(path), "/dev/%s", desc);
    return gpiod_chip_open(path);
  }
  for (unsigned i = 0; i < kMaxChips; ++i) {  // a label: search the chips
    std::snprintf(path, sizeof(path), "/dev/gpiochip%u", i);
    gpiod_chip* chip = gpiod_chip_open(path);
    if (chip == nullptr) continue;
    gpiod_chip_info* info = gpiod_chip_get_info(chip);
    const bool match = info != nullptr && std::strcmp(gpiod_chip_info_get_label(info), desc) == 0;
    if (info != nullptr) gpiod_chip_info_free(info);
    if (match) return chip;
    gpiod_chip_close(chip);
  }
  errno = ENOENT;
  return nullptr;
}

class LibgpiodV2 final : public GpiodApi {
 public:
  Line request_events(const char* chip_name, unsigned offset, EdgeSelect edges, uint32_t debounce_us,
                      const char* consumer) override {
    gpiod_line_settings* s = gpiod_line_settings_new();
    if (s == nullptr) return nullptr;
    gpiod_line_settings_set_direction(s, GPIOD_LINE_DIRECTION_INPUT);
    gpiod_line_settings_set_edge_detection(s, edges == EdgeSelect::kRising    ? GPIOD_LINE_EDGE_RISING
                                              : edges == EdgeSelect::kFalling ? GPIOD_LINE_EDGE_FALLING
                                                                              : GPIOD_LINE_EDGE_BOTH);
    gpiod_line_settings_set_event_clock(s, GPIOD_LINE_CLOCK_MONOTONIC);  // the HAL clock's base
    gpiod_line_settings_set_debounce_period_us(s, debounce_us);
    V2Line* line = request(chip_name, offset, consumer, s);
    gpiod_line_settings_free(s);
    if (line == nullptr) return nullptr;
    line->buffer = gpiod_edge_event_buffer_new(1);
    if (line->buffer == nullptr) {
      release(line);
      errno = ENOMEM;
      return nullptr;
    }
    return line;
  }
  Line request_output(const char* chip_name, unsigned offset, const char* consumer, int value) override {
    gpiod_line_settings* s = gpiod_line_settings_new();
    if (s == nullptr) return nullptr;
    gpiod_line_settings_set_direction(s, GPIOD_LINE_DIRECTION_OUTPUT);
    gpiod_line_settings_set_output_value(s, value ? GPIOD_LINE_VALUE_ACTIVE : GPIOD_LINE_VALUE_INACTIVE);
    V2Line* line = request(chip_name, offset, consumer, s);
    gpiod_line_settings_free(s);
    return line;
  }
  void release(Line l) override {
    auto* line = static_cast<V2Line*>(l);
    if (line == nullptr) return;
    if (line->buffer != nullptr) gpiod_edge_event_buffer_free(line->buffer);
    if (line->request != nullptr) gpiod_line_request_release(line->request);
    if (line->chip != nullptr) gpiod_chip_close(line->chip);
    delete line;
  }
  int wait_event(Line l, uint32_t timeout_ms) override {
    return gpiod_line_request_wait_edge_events(static_cast<V2Line*>(l)->request, int64_t(timeout_ms) * 1000000);
  }
  int read_event(Line l, GpiodRawEvent& event) override {
    auto* line = static_cast<V2Line*>(l);
    if (gpiod_line_request_read_edge_events(line->request, line->buffer, 1) < 1) return -1;
    gpiod_edge_event* ev = gpiod_edge_event_buffer_get_event(line->buffer, 0);
    if (ev == nullptr) return -1;
    event.kind = gpiod_edge_event_get_event_type(ev) == GPIOD_EDGE_EVENT_RISING_EDGE ? EdgeKind::kRising
                                                                                    : EdgeKind::kFalling;
    event.stamp_ns = gpiod_edge_event_get_timestamp_ns(ev);
    return 0;
  }
  int set_value(Line l, int value) override {
    auto* line = static_cast<V2Line*>(l);
    return gpiod_line_request_set_value(line->request, line->offset,
                                        value ? GPIOD_LINE_VALUE_ACTIVE : GPIOD_LINE_VALUE_INACTIVE);
  }
  bool kernel_debounce() const override { return true; }  // the v2 uAPI debounces (Linux >= 5.10)

 private:
  // Opens the chip and requests one line with settings `s`; null with errno on failure.
  static V2Line* request(const char* chip_name, unsigned offset, const char* consumer, gpiod_line_settings* s) {
    auto* line = new (std::nothrow) V2Line;
    if (line == nullptr) {
      errno = ENOMEM;
      return nullptr;
    }
    line->offset = offset;
    line->chip = open_chip(chip_name);
    gpiod_line_config* lc = line->chip ? gpiod_line_config_new() : nullptr;
    gpiod_request_config* rc = lc ? gpiod_request_config_new() : nullptr;
    if (rc != nullptr && gpiod_line_config_add_line_settings(lc, &offset, 1, s) == 0) {
      gpiod_request_config_set_consumer(rc, consumer);
      line->request = gpiod_chip_request_lines(line->chip, rc, lc);
    }
    const int e = errno;
    if (rc != nullptr) gpiod_request_config_free(rc);
    if (lc != nullptr) gpiod_line_config_free(lc);
    if (line->request == nullptr) {
      if (line->chip != nullptr) gpiod_chip_close(line->chip);
      delete line;
      errno = e != 0 ? e : EIO;
      return nullptr;
    }
    return line;
  }
};

}  // namespace

GpiodApi* libgpiod_api() {
  static LibgpiodV2 api;
  return &api;
}

}  // namespace edgefuse::hal
