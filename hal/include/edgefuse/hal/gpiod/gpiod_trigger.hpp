// GPIO trigger lines through libgpiod: edge events with the kernel's time stamps on the chip and
// offset from the board's pin map (board/<name>/pins.toml), software debounce where the library
// has none (libgpiod 1.6), EINTR retried, a vanished chip reported as kNoDevice.
#pragma once

#include "edgefuse/hal/clock.hpp"
#include "edgefuse/hal/trigger.hpp"
#include "edgefuse/hal/gpiod/gpiod_api.hpp"

namespace edgefuse::hal {

struct GpiodLineConfig {
  const char* chip = "gpiochip0";    //!< chip name, path, label or number
  unsigned offset = 0;               //!< line offset on the chip
  const char* consumer = "edgefuse"; //!< label shown by gpioinfo
};

class GpiodTriggerInput final : public TriggerInput {
 public:
  //! \param config chip and offset  \param api libgpiod (or a fake)  \param clock remaining-time bookkeeping
  GpiodTriggerInput(const GpiodLineConfig& config, GpiodApi& api, Clock& clock)
      : config_(config), api_(api), clock_(clock) {}
  ~GpiodTriggerInput() override { stop(); }
  HalStatus start(EdgeSelect edges, uint32_t debounce_us) override;
  void stop() override;
  HalStatus wait_edge(TriggerEdge& edge, uint32_t timeout_ms) override;
  uint32_t debounced() const { return debounced_; }

 private:
  GpiodLineConfig config_;
  GpiodApi& api_;
  Clock& clock_;
  GpiodApi::Line line_ = nullptr;
  uint32_t debounce_us_ = 0;
  bool have_last_ = false;
  uint64_t last_us_ = 0;
  uint32_t sequence_ = 0;
  uint32_t debounced_ = 0;
};

class GpiodTriggerOutput final : public TriggerOutput {
 public:
  //! \param config chip and offset  \param api libgpiod (or a fake)  \param clock pulse timing
  GpiodTriggerOutput(const GpiodLineConfig& config, GpiodApi& api, Clock& clock)
      : config_(config), api_(api), clock_(clock) {}
  ~GpiodTriggerOutput() override { stop(); }
  HalStatus start() override;
  void stop() override;
  HalStatus set(bool high) override;
  HalStatus pulse(uint32_t width_us) override;

 private:
  GpiodLineConfig config_;
  GpiodApi& api_;
  Clock& clock_;
  GpiodApi::Line line_ = nullptr;
};

}  // namespace edgefuse::hal
