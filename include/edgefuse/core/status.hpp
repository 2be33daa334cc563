// Error reporting without exceptions: functions in src/ return a Status.
#pragma once

namespace edgefuse {

enum class Status {
  kOk = 0,
  kInvalidArgument,   //!< a parameter is out of its allowed range
  kCapacityExceeded,  //!< the request does not fit the board's static capacity
  kNotInitialised,    //!< used before init()
  kOutputTruncated,   //!< the result was longer than the output buffer; what fits was written
};

//! A short, stable text for a status (for logs and the console).
inline const char* to_string(Status s) {
  switch (s) {
    case Status::kOk: return "ok";
    case Status::kInvalidArgument: return "invalid argument";
    case Status::kCapacityExceeded: return "capacity exceeded";
    case Status::kNotInitialised: return "not initialised";
    case Status::kOutputTruncated: return "output truncated";
  }
  return "unknown";
}

}  // namespace edgefuse
