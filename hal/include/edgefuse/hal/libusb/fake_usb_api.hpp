// A fake libusb for host tests: a bus whose devices the test plugs and unplugs; hot-plug
// callbacks fire from handle_events() as libusb's do. Never blocks.
#pragma once

#include <vector>

#include "edgefuse/hal/libusb/usb_api.hpp"

namespace edgefuse::hal {

class FakeUsbApi final : public UsbApi {
 public:
  bool hotplug_supported = true;
  int init_result = 0;
  std::vector<UsbId> bus;  //!< connected devices

  //! Plugs a device (the callback fires at the next handle_events()).
  //! \param id the device
  void plug(const UsbId& id) {
    bus.push_back(id);
    pending_.push_back({id, true});
  }
  //! Unplugs the first device with this VID:PID.
  //! \param vid vendor  \param pid product
  void unplug(uint16_t vid, uint16_t pid) {
    for (std::size_t i = 0; i < bus.size(); ++i)
      if (bus[i].vendor_id == vid && bus[i].product_id == pid) {
        pending_.push_back({bus[i], false});
        bus.erase(bus.begin() + long(i));
        return;
      }
  }

  int init() override { return init_result; }
  void exit() override { fn_ = nullptr; }
  int enumerate(UsbId* ids, int capacity) override {
    int n = 0;
    for (const UsbId& id : bus)
      if (n < capacity) ids[n++] = id;
    return n;
  }
  bool has_hotplug() override { return hotplug_supported; }
  int register_hotplug(HotplugFn fn, void* user) override {
    fn_ = fn;
    user_ = user;
    return 0;
  }
  int handle_events(uint32_t) override {
    if (fn_)
      for (const Pending& p : pending_) fn_(user_, p.id, p.arrived);
    pending_.clear();
    return 0;
  }
  const char* error_name(int) override { return "LIBUSB_ERROR_OTHER"; }

 private:
  struct Pending {
    UsbId id;
    bool arrived;
  };
  std::vector<Pending> pending_;
  HotplugFn fn_ = nullptr;
  void* user_ = nullptr;
};

}  // namespace edgefuse::hal
