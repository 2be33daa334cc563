// The libusb device monitor against a fake libusb (enumeration at start, hot-plug arrivals and
// departures of the board's VID:PIDs, unwatched devices ignored, two identical sensors, the
// polling fallback) and against the real libusb (starts and enumerates on this host).
#include <cstring>

#include "edgefuse/hal/libusb/fake_usb_api.hpp"
#include "edgefuse/hal/libusb/usb_device_monitor.hpp"
#include "edgefuse/hal/null/null_backends.hpp"
#include "test_support.hpp"

using namespace edgefuse;
using namespace edgefuse::hal;

namespace {
const UsbId kXtion{0x1d27, 0x0601, 1, 4};
const UsbId kTof{0x1c28, 0xc012, 1, 5};
const UsbId kMouse{0x046d, 0xc077, 1, 6};
}  // namespace

TEST_GROUP(HalLibusb) {
  FakeUsbApi api;
  ManualClock clock;
};

TEST(HalLibusb, PresentSensorsArriveAtStartAndHotplugFollowsThem) {
  api.bus = {kXtion, kMouse};
  UsbDeviceMonitor mon(api, clock);
  CHECK(mon.watch("xtion", 0x1d27, 0x0601));
  CHECK(mon.watch("tof", 0x1c28, 0xc012));
  CHECK(mon.start() == HalStatus::kOk);
  CHECK(mon.hotplug());
  DeviceEvent e;
  CHECK(mon.next_event(e, 10) == HalStatus::kOk);
  CHECK(e.kind == DeviceEventKind::kArrived);
  STRCMP_EQUAL("xtion", e.device);
  CHECK_EQUAL(0x1d27, e.vendor_id);
  CHECK(mon.next_event(e, 10) == HalStatus::kTimeout);
  CHECK(mon.present("xtion"));
  CHECK_FALSE(mon.present("tof"));
  CHECK(mon.present("laser"));  // not a USB device of the board

  api.plug(kTof);
  api.plug(kMouse);  // not watched
  CHECK(mon.next_event(e, 10) == HalStatus::kOk);
  STRCMP_EQUAL("tof", e.device);
  CHECK(e.kind == DeviceEventKind::kArrived);
  CHECK(mon.next_event(e, 10) == HalStatus::kTimeout);
  CHECK(mon.present("tof"));

  api.unplug(0x1d27, 0x0601);
  CHECK(mon.next_event(e, 10) == HalStatus::kOk);
  STRCMP_EQUAL("xtion", e.device);
  CHECK(e.kind == DeviceEventKind::kDeparted);
  CHECK_FALSE(mon.present("xtion"));
  api.plug(kXtion);
  CHECK(mon.next_event(e, 10) == HalStatus::kOk);
  CHECK(e.kind == DeviceEventKind::kArrived);
  CHECK(mon.present("xtion"));
}

TEST(HalLibusb, TwoIdenticalSensorsStayPresentUntilBothLeave) {
  UsbDeviceMonitor mon(api, clock);
  mon.watch("xtion", 0x1d27, 0x0601);
  CHECK(mon.start() == HalStatus::kOk);
  api.plug(kXtion);
  api.plug(UsbId{0x1d27, 0x0601, 2, 3});
  DeviceEvent e;
  CHECK(mon.next_event(e, 10) == HalStatus::kOk);
  CHECK(mon.next_event(e, 10) == HalStatus::kOk);
  api.unplug(0x1d27, 0x0601);
  CHECK(mon.next_event(e, 10) == HalStatus::kOk);
  CHECK(e.kind == DeviceEventKind::kDeparted);
  CHECK(mon.present("xtion"));
  api.unplug(0x1d27, 0x0601);
  CHECK(mon.next_event(e, 10) == HalStatus::kOk);
  CHECK_FALSE(mon.present("xtion"));
}

TEST(HalLibusb, PollingFallbackWithoutHotplug) {
  api.hotplug_supported = false;
  UsbDeviceMonitor mon(api, clock);
  mon.watch("tof", 0x1c28, 0xc012);
  CHECK(mon.start() == HalStatus::kOk);
  CHECK_FALSE(mon.hotplug());
  DeviceEvent e;
  CHECK(mon.next_event(e, 10) == HalStatus::kTimeout);
  api.bus.push_back(kTof);
  CHECK(mon.next_event(e, 10) == HalStatus::kOk);
  STRCMP_EQUAL("tof", e.device);
  api.bus.clear();
  CHECK(mon.next_event(e, 10) == HalStatus::kOk);
  CHECK(e.kind == DeviceEventKind::kDeparted);
}

TEST(HalLibusb, InitFailureIsReported) {
  api.init_result = -99;
  UsbDeviceMonitor mon(api, clock);
  CHECK(mon.start() == HalStatus::kIoError);
  STRCMP_CONTAINS("libusb init", mon.last_error());
}

TEST(HalLibusb, RealLibusbStartsAndEnumerates) {
  UsbDeviceMonitor mon(libusb_api(), clock);
  mon.watch("xtion", 0x1d27, 0x0601);
  const HalStatus s = mon.start();
  if (s != HalStatus::kOk) {  // containers without a USB bus may refuse the context
    std::printf("\n  SKIP: %s", mon.last_error());
    return;
  }
  DeviceEvent e;
  const HalStatus n = mon.next_event(e, 10);
  CHECK(n == HalStatus::kOk || n == HalStatus::kTimeout);
  mon.stop();
}
