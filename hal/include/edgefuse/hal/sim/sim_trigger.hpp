// Simulated trigger line: edges either fired by a SimTriggerOutput (the robot controller's pulse)
// or free-running at a fixed period; the input applies debounce as a GPIO line would. Edges are
// stamped on the HAL clock like gpiod's kernel stamps.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <mutex>

#include "edgefuse/hal/clock.hpp"
#include "edgefuse/hal/trigger.hpp"

namespace edgefuse::hal {

//! The wire between a SimTriggerOutput and a SimTriggerInput: a small ring of edges.
class SimTriggerLine {
 public:
  static constexpr int kCapacity = 64;
  //! Queues an edge; the oldest is lost when the ring is full (counted).
  //! \param edge kind and stamp
  void push(const TriggerEdge& edge);
  //! Waits for an edge until `deadline`.
  //! \param edge receives it  \param timeout_ms longest wait (real time)
  bool pop(TriggerEdge& edge, uint32_t timeout_ms);
  uint32_t overflows() const { return overflows_; }

 private:
  std::mutex mutex_;
  std::condition_variable cv_;
  TriggerEdge ring_[kCapacity];
  int head_ = 0, count_ = 0;
  uint32_t overflows_ = 0;
};

class SimTriggerOutput final : public TriggerOutput {
 public:
  //! \param line the wire  \param clock stamps
  SimTriggerOutput(SimTriggerLine& line, Clock& clock) : line_(line), clock_(clock) {}
  HalStatus start() override { started_ = true; return HalStatus::kOk; }
  void stop() override { started_ = false; }
  HalStatus set(bool high) override;
  HalStatus pulse(uint32_t width_us) override;

 private:
  SimTriggerLine& line_;
  Clock& clock_;
  bool started_ = false;
  bool level_ = false;
};

class SimTriggerInput final : public TriggerInput {
 public:
  //! Edges from `line` (fired by a SimTriggerOutput).
  //! \param line the wire  \param clock stamps and pacing
  SimTriggerInput(SimTriggerLine& line, Clock& clock) : line_(&line), clock_(clock) {}
  //! Free-running rising edges every period_us (an encoder or a fixed-rate trigger).
  //! \param period_us edge period  \param clock stamps and pacing
  SimTriggerInput(uint32_t period_us, Clock& clock) : clock_(clock), period_us_(period_us) {}

  HalStatus start(EdgeSelect edges, uint32_t debounce_us) override;
  void stop() override { started_ = false; }
  HalStatus wait_edge(TriggerEdge& edge, uint32_t timeout_ms) override;
  uint32_t debounced() const { return debounced_; }
  //! Free-running edges lost while the reader was late (beyond kQueuedEdges waiting).
  uint32_t lost() const { return lost_; }
  //! Edges a free-running line keeps for a late reader (a GPIO's kernel event buffer).
  static constexpr uint32_t kQueuedEdges = 16;

 private:
  bool accept(const TriggerEdge& e) const;
  void skip_lost_edges(uint64_t now_us);

  SimTriggerLine* line_ = nullptr;
  Clock& clock_;
  uint32_t period_us_ = 0;
  bool started_ = false;
  EdgeSelect select_ = EdgeSelect::kRising;
  uint32_t debounce_us_ = 0;
  uint64_t next_us_ = 0;
  uint64_t last_accepted_us_ = 0;
  bool have_last_ = false;
  uint32_t sequence_ = 0;
  uint32_t debounced_ = 0;
  uint32_t lost_ = 0;
};

}  // namespace edgefuse::hal
