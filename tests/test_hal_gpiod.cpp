// The gpiod trigger backend against a fake libgpiod: kernel stamps carried through, software
// debounce (libgpiod 1.6) or the kernel's (libgpiod 2), EINTR, timeouts, a vanished chip, the
// output line's pulse; and the real libgpiod 1.6 reporting a missing chip as kNoDevice.
#include "edgefuse/hal/gpiod/fake_gpiod_api.hpp"
#include "edgefuse/hal/gpiod/gpiod_trigger.hpp"
#include "edgefuse/hal/null/null_backends.hpp"
#include "test_support.hpp"

using namespace edgefuse;
using namespace edgefuse::hal;

TEST_GROUP(HalGpiod) {
  FakeGpiodApi api;
  ManualClock clock;
  GpiodLineConfig line;
  void setup() override {
    line.chip = "gpiochip0";
    line.offset = 17;
  }
};

TEST(HalGpiod, EdgesCarryTheKernelStampAndASequence) {
  GpiodTriggerInput in(line, api, clock);
  CHECK(in.start(EdgeSelect::kBoth, 0) == HalStatus::kOk);
  CHECK(api.requested_edges == EdgeSelect::kBoth);
  api.edge(EdgeKind::kRising, 1234567891234ull);
  api.edge(EdgeKind::kFalling, 1234567991234ull);
  TriggerEdge e;
  CHECK(in.wait_edge(e, 10) == HalStatus::kOk);
  CHECK(e.kind == EdgeKind::kRising);
  CHECK_EQUAL(1234567891u, e.stamp_us);
  CHECK_EQUAL(0u, e.sequence);
  CHECK(in.wait_edge(e, 10) == HalStatus::kOk);
  CHECK(e.kind == EdgeKind::kFalling);
  CHECK_EQUAL(1234567991u, e.stamp_us);
  CHECK_EQUAL(1u, e.sequence);
  CHECK(in.wait_edge(e, 10) == HalStatus::kTimeout);
}

TEST(HalGpiod, SoftwareDebounceWithLibgpiod16) {
  GpiodTriggerInput in(line, api, clock);
  CHECK(in.start(EdgeSelect::kRising, 500) == HalStatus::kOk);
  api.edge(EdgeKind::kRising, 1000000000ull);
  api.edge(EdgeKind::kRising, 1000300000ull);  // 300 us after the first: a bounce
  api.edge(EdgeKind::kRising, 1002000000ull);  // 2 ms after: a real edge
  TriggerEdge e;
  CHECK(in.wait_edge(e, 10) == HalStatus::kOk);
  CHECK_EQUAL(1000000u, e.stamp_us);
  CHECK(in.wait_edge(e, 10) == HalStatus::kOk);
  CHECK_EQUAL(1002000u, e.stamp_us);
  CHECK_EQUAL(1u, e.sequence);
  CHECK_EQUAL(1u, in.debounced());
}

TEST(HalGpiod, KernelDebounceIsLeftToTheKernel) {
  api.debounce_in_kernel = true;  // libgpiod 2
  GpiodTriggerInput in(line, api, clock);
  CHECK(in.start(EdgeSelect::kRising, 500) == HalStatus::kOk);
  CHECK_EQUAL(500u, api.requested_debounce_us);
  api.edge(EdgeKind::kRising, 1000000000ull);
  api.edge(EdgeKind::kRising, 1000300000ull);  // the kernel let it through: it counts
  TriggerEdge e;
  CHECK(in.wait_edge(e, 10) == HalStatus::kOk);
  CHECK(in.wait_edge(e, 10) == HalStatus::kOk);
  CHECK_EQUAL(0u, in.debounced());
}

TEST(HalGpiod, EintrIsRetriedAndAVanishedChipIsNoDevice) {
  GpiodTriggerInput in(line, api, clock);
  CHECK(in.start(EdgeSelect::kRising, 0) == HalStatus::kOk);
  api.wait_eintr = 3;
  api.edge(EdgeKind::kRising, 5000000ull);
  TriggerEdge e;
  CHECK(in.wait_edge(e, 10) == HalStatus::kOk);
  CHECK_EQUAL(5000u, e.stamp_us);
  api.chip_present = false;
  CHECK(in.wait_edge(e, 10) == HalStatus::kNoDevice);
  in.stop();
  CHECK(in.start(EdgeSelect::kRising, 0) == HalStatus::kNoDevice);
  api.chip_present = true;
  CHECK(in.start(EdgeSelect::kRising, 0) == HalStatus::kOk);
  CHECK_EQUAL(api.requests - 1, api.releases);
}

TEST(HalGpiod, WrongChipOrOffsetFailsAtStart) {
  line.chip = "gpiochip7";
  GpiodTriggerInput in(line, api, clock);
  CHECK(in.start(EdgeSelect::kRising, 0) == HalStatus::kNoDevice);
  line.chip = "gpiochip0";
  line.offset = 99;
  GpiodTriggerInput in2(line, api, clock);
  CHECK(in2.start(EdgeSelect::kRising, 0) == HalStatus::kIoError);
}

TEST(HalGpiod, OutputPulseDrivesHighThenLow) {
  GpiodTriggerOutput out(line, api, clock);
  CHECK(out.set(true) == HalStatus::kNotStarted);
  CHECK(out.start() == HalStatus::kOk);
  CHECK_EQUAL(0, api.output_value);
  const uint64_t t0 = clock.now_us();
  CHECK(out.pulse(100) == HalStatus::kOk);
  CHECK_EQUAL(2, api.output_writes);
  CHECK_EQUAL(0, api.output_value);
  CHECK_EQUAL(t0 + 100u, clock.now_us());
}

TEST(HalGpiod, RealLibgpiodReportsAMissingChip) {
  GpiodApi* real = libgpiod_api();
  CHECK(real != nullptr);
  GpiodLineConfig missing;
  missing.chip = "edgefuse-no-such-chip";
  GpiodTriggerInput in(missing, *real, clock);
  const HalStatus s = in.start(EdgeSelect::kRising, 0);
  CHECK(s == HalStatus::kNoDevice || s == HalStatus::kIoError);
}
