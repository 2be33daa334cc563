// What the runtime publishes, in plain types: its heartbeats and numbered results. The pose link
// (link::LinkPublisher) encodes them into frames; nothing on this side knows the wire format.
#pragma once

#include <cstdint>

#include "edgefuse/runtime/pipeline.hpp"

namespace edgefuse::runtime {

enum class RuntimeState { kIdle, kMapping, kLocalize, kReport };
const char* to_string(RuntimeState s);

//! A result's outcome.
enum class ResultStatus : uint8_t { kOk, kNoObjects, kFailed };

struct HeartbeatInfo {
  uint32_t seq = 0;
  uint64_t stamp_us = 0;
  RuntimeState state = RuntimeState::kIdle;
  TrackingState tracking = TrackingState::kOff;
  float fps = 0;
  uint32_t frames = 0;
  uint32_t drops = 0;
  uint32_t results = 0;   //!< results sent so far
  uint32_t uptime_s = 0;
};

struct ResultInfo {
  uint32_t seq = 0;
  uint64_t stamp_us = 0;  //!< capture stamp of the last frame in the map
  ResultStatus status = ResultStatus::kOk;
  const ObjectResult* objects = nullptr;
  int count = 0;
};

class Publisher {
 public:
  virtual ~Publisher() = default;
  //! \param r a numbered result (sent as often as report.repeat says)
  virtual void publish(const ResultInfo& r) = 0;
  //! \param h a heartbeat
  virtual void publish(const HeartbeatInfo& h) = 0;
};

}  // namespace edgefuse::runtime
