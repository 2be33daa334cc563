// libusb 1.0 behind UsbApi.
#include <libusb.h>

#include "edgefuse/hal/libusb/usb_api.hpp"

namespace edgefuse::hal {

namespace {

class Libusb final : public UsbApi {
 public:
  int init() override { return ctx_ ? 0 : libusb_init(&ctx_); }
  void exit() override {
    if (!ctx_) return;
    if (registered_) libusb_hotplug_deregister_callback(ctx_, handle_);
    registered_ = false;
    libusb_exit(ctx_);
    ctx_ = nullptr;
  }
  int enumerate(UsbId* ids, int capacity) override {
    libusb_device** list = nullptr;
    const ssize_t n = libusb_get_device_list(ctx_, &list);
    if (n < 0) return int(n);
    int count = 0;
    for (ssize_t i = 0; i < n && count < capacity; ++i) {
      libusb_device_descriptor d{};
      if (libusb_get_device_descriptor(list[i], &d) != 0) continue;
      ids[count++] = UsbId{d.idVendor, d.idProduct, libusb_get_bus_number(list[i]), libusb_get_device_address(list[i])};
    }
    libusb_free_device_list(list, 1);
    return count;
  }
  bool has_hotplug() override { return libusb_has_capability(LIBUSB_CAP_HAS_HOTPLUG) != 0; }
  int register_hotplug(HotplugFn fn, void* user) override {
    fn_ = fn;
    user_ = user;
    const int r = libusb_hotplug_register_callback(
        ctx_, libusb_hotplug_event(LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED | LIBUSB_HOTPLUG_EVENT_DEVICE_LEFT),
        libusb_hotplug_flag(0), LIBUSB_HOTPLUG_MATCH_ANY, LIBUSB_HOTPLUG_MATCH_ANY, LIBUSB_HOTPLUG_MATCH_ANY,
        &Libusb::on_hotplug, this, &handle_);
    registered_ = r == 0;
    return r;
  }
  int handle_events(uint32_t timeout_ms) override {
    timeval tv{};
    tv.tv_sec = long(timeout_ms / 1000u);
    tv.tv_usec = long(timeout_ms % 1000u) * 1000;
    return libusb_handle_events_timeout_completed(ctx_, &tv, nullptr);
  }
  const char* error_name(int code) override { return libusb_error_name(code); }

 private:
  static int LIBUSB_CALL on_hotplug(libusb_context*, libusb_device* dev, libusb_hotplug_event event, void* self) {
    auto* me = static_cast<Libusb*>(self);
    libusb_device_descriptor d{};
    if (libusb_get_device_descriptor(dev, &d) != 0 || !me->fn_) return 0;
    me->fn_(me->user_, UsbId{d.idVendor, d.idProduct, libusb_get_bus_number(dev), libusb_get_device_address(dev)},
            event == LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED);
    return 0;  // stay registered
  }

  libusb_context* ctx_ = nullptr;
  libusb_hotplug_callback_handle handle_ = 0;
  bool registered_ = false;
  HotplugFn fn_ = nullptr;
  void* user_ = nullptr;
};

}  // namespace

UsbApi& libusb_api() {
  static Libusb api;
  return api;
}

}  // namespace edgefuse::hal
