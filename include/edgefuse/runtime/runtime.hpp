// The on-board runtime's logic: the state machine IDLE -> MAPPING -> LOCALIZE -> REPORT driven by
// console commands and the still-period trigger, heartbeats and results out over the link, and the
// console's service (status, calibration, parameters). OS-free: edgefused supplies the pipeline,
// the calibration storage, the publisher (the pose link encodes what it is given) and the clock.
// No heap.
#pragma once

#include <cstddef>
#include <cstdint>

#include "edgefuse/runtime/calibration.hpp"
#include "edgefuse/runtime/console_service.hpp"
#include "edgefuse/runtime/params.hpp"
#include "edgefuse/runtime/pipeline.hpp"
#include "edgefuse/runtime/publisher.hpp"

namespace edgefuse::runtime {

//! Persistent calibration (the file store on the board).
class CalibrationStorage {
 public:
  virtual ~CalibrationStorage() = default;
  //! \param d data  \param msg result text  \param cap its capacity
  virtual bool save(const CalibrationData& d, char* msg, size_t cap) = 0;
  virtual bool load(CalibrationData& d, char* msg, size_t cap) = 0;
};

//! Told of every result once (whatever report.repeat says): the robot session's object list.
class ResultListener {
 public:
  virtual ~ResultListener() = default;
  //! \param r the numbered result, objects below localize.min_score already dropped
  virtual void result_sent(const ResultInfo& r) = 0;
};

class Runtime : public ConsoleService {
 public:
  //! \param pipeline produces frames and poses
  //! \param params   runtime parameters (shared with the console)
  //! \param storage  calibration persistence
  //! \param out      result and heartbeat output
  Runtime(Pipeline& pipeline, ParamStore& params, CalibrationStorage& storage, Publisher& out)
      : pipeline_(pipeline), params_(params), storage_(storage), out_(out) {}

  //! Sets the calibration loaded at start-up.
  void set_calibration(const CalibrationData& d) {
    calib_ = d;
    pipeline_.calibration_changed(calib_);
  }
  const CalibrationData& calibration() const { return calib_; }
  //! \param l told of every result (null: nobody)
  void set_result_listener(ResultListener* l) { listener_ = l; }

  //! Advances the pipeline and the state machine; sends due heartbeats and results.
  //! \param now_us monotonic time in microseconds
  void tick(uint64_t now_us);

  RuntimeState state() const { return state_; }
  uint32_t results_sent() const { return result_seq_; }
  uint32_t heartbeats_sent() const { return heartbeat_seq_; }
  int log_level() const { return params_.get_int(kLogLevel); }

  // ConsoleService
  CmdResult status(ConsoleWriter& out) override;
  CmdResult calib_fuse(const char* from, const char* to, ConsoleWriter& out) override;
  CmdResult calib_show(ConsoleWriter& out) override;
  CmdResult calib_set(const char* sensor, const float tq[7]) override;
  CmdResult calib_intrinsics(const char* sensor, const float k[4]) override;
  CmdResult calib_save() override;
  CmdResult calib_load() override;
  CmdResult calib_reset() override;
  CmdResult scan(bool start) override;
  CmdResult map_reset() override;
  CmdResult localize() override;
  CmdResult model_list(ConsoleWriter& out) override;
  CmdResult log_level(int level) override;
  CmdResult param_changed(int id) override;

 private:
  void send_result();
  void send_heartbeat(uint64_t now_us);
  bool begin_localize(uint64_t now_us, const char** why);

  Pipeline& pipeline_;
  ParamStore& params_;
  CalibrationStorage& storage_;
  Publisher& out_;
  ResultListener* listener_ = nullptr;
  CalibrationData calib_;
  RuntimeState state_ = RuntimeState::kIdle;
  bool scanning_ = false;       // return to MAPPING after a report
  bool still_armed_ = true;     // the still trigger fires once per still period
  bool localize_requested_ = false;
  uint64_t now_us_ = 0;
  uint64_t start_us_ = 0;
  uint64_t next_heartbeat_us_ = 0;
  uint32_t result_seq_ = 0;
  uint32_t heartbeat_seq_ = 0;
  LocalizationOutcome result_;  // the result being collected and reported
  char text_[160] = {};         // reply messages that outlive a call
};

}  // namespace edgefuse::runtime
