// Results of HAL calls. Device code never throws: every call returns one of these, and the
// acquisition runtime decides what a result means for the stream (retry, reopen, wait for replug).
#pragma once

namespace edgefuse::hal {

enum class HalStatus {
  kOk = 0,
  kTimeout,           //!< nothing arrived within timeout_ms (the device may recover)
  kNoDevice,          //!< the device vanished or is not present (ENODEV, unplugged)
  kBadFrame,          //!< a frame arrived but is unusable (size, format, truncated)
  kNotStarted,        //!< a stream call before start()
  kInvalidArgument,   //!< a parameter is out of range (mode index, buffer too small)
  kIoError,           //!< the driver or library reported another error
  kEndOfStream,       //!< a recording has no more frames
  kInterrupted,       //!< a blocking wait was cut short (stop requested)
};

//! A short, stable text for logs and the status command.
inline const char* to_string(HalStatus s) {
  switch (s) {
    case HalStatus::kOk: return "ok";
    case HalStatus::kTimeout: return "timeout";
    case HalStatus::kNoDevice: return "no device";
    case HalStatus::kBadFrame: return "bad frame";
    case HalStatus::kNotStarted: return "not started";
    case HalStatus::kInvalidArgument: return "invalid argument";
    case HalStatus::kIoError: return "i/o error";
    case HalStatus::kEndOfStream: return "end of stream";
    case HalStatus::kInterrupted: return "interrupted";
  }
  return "unknown";
}

}  // namespace edgefuse::hal
