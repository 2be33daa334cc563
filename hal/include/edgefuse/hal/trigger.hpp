// GPIO edges with kernel timestamps (libgpiod) or simulated ones: the line scanner's trigger.
#pragma once

#include <cstdint>

#include "edgefuse/hal/hal_status.hpp"

namespace edgefuse::hal {

enum class EdgeKind : uint8_t { kRising, kFalling };
enum class EdgeSelect : uint8_t { kRising, kFalling, kBoth };

struct TriggerEdge {
  EdgeKind kind = EdgeKind::kRising;
  uint64_t stamp_us = 0;   //!< when the kernel saw the edge (HAL clock base)
  uint32_t sequence = 0;   //!< edges delivered since start (gaps: edges lost or debounced)
};

class TriggerInput {
 public:
  virtual ~TriggerInput() = default;
  //! Requests edge events on the line.
  //! \param edges which edges to report
  //! \param debounce_us edges closer than this to the last accepted one are ignored (0: none)
  virtual HalStatus start(EdgeSelect edges, uint32_t debounce_us) = 0;
  virtual void stop() = 0;
  //! Waits up to timeout_ms for the next accepted edge.
  //! \param edge receives the edge  \param timeout_ms longest wait
  virtual HalStatus wait_edge(TriggerEdge& edge, uint32_t timeout_ms) = 0;
};

class TriggerOutput {
 public:
  virtual ~TriggerOutput() = default;
  virtual HalStatus start() = 0;
  virtual void stop() = 0;
  //! Drives the line.
  //! \param high true: logic high
  virtual HalStatus set(bool high) = 0;
  //! A high pulse of `width_us` (fires a sensor).
  //! \param width_us pulse width in microseconds
  virtual HalStatus pulse(uint32_t width_us) = 0;
};

}  // namespace edgefuse::hal
