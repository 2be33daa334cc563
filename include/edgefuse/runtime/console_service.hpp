// What the serial console asks of the runtime. The console only parses and checks; everything it
// does goes through this interface, which edgefused implements (and tests replace by a fake).
// Methods must return quickly: long work (calibration, localisation) is started here and runs in
// the pipeline, so a console command never stalls it.
#pragma once

#include <cstddef>

namespace edgefuse::runtime {

//! Error codes of console replies (`ERR <code> <message>`); stable, documented in docs/GUIDE.md.
enum class ConsoleError : int {
  kOk = 0,
  kUnknownCommand = 1,
  kBadArguments = 2,
  kLineTooLong = 3,
  kOutOfRange = 4,
  kWrongState = 5,
  kFailed = 6,
  kNotFound = 7,
  kStorage = 8,
  kBadCharacter = 9,
};

//! Result of a service call: kOk, or an error with a short message (static or owned by the service).
struct CmdResult {
  ConsoleError code = ConsoleError::kOk;
  const char* message = "";
  static CmdResult ok() { return {}; }
  static CmdResult error(ConsoleError c, const char* m) { return {c, m}; }
};

//! Where a command prints its reply lines (before the final OK / ERR).
class ConsoleWriter {
 public:
  virtual ~ConsoleWriter() = default;
  //! Prints one line (printf format; the line end is added; long lines are cut at 255 bytes).
  void line(const char* fmt, ...) __attribute__((format(printf, 2, 3)));
  //! Raw bytes to the terminal.
  //! \param s bytes
  //! \param n their number
  virtual void write(const char* s, size_t n) = 0;
};

class ConsoleService {
 public:
  virtual ~ConsoleService() = default;
  //! state, fps, frame and drop counters, tracking state, device states
  virtual CmdResult status(ConsoleWriter& out) = 0;
  //! Starts the rigid-pair calibration of sensor `to` against the map of sensor `from`.
  virtual CmdResult calib_fuse(const char* from, const char* to, ConsoleWriter& out) = 0;
  virtual CmdResult calib_show(ConsoleWriter& out) = 0;
  //! Sets the mounting of `sensor` (T_rig_sensor), or with `sensor` "flange" the hand-eye pose
  //! T_flange_rig, with "bin" the bin pose T_world_bin: translation (m), unit quaternion x y z w.
  virtual CmdResult calib_set(const char* sensor, const float tq[7]) = 0;
  //! Overrides the pinhole intrinsics of `sensor`: fx fy cx cy in pixels (k[0..3]).
  virtual CmdResult calib_intrinsics(const char* sensor, const float k[4]) = 0;
  virtual CmdResult calib_save() = 0;
  virtual CmdResult calib_load() = 0;
  virtual CmdResult calib_reset() = 0;
  //! `scan start` (true) / `scan stop` (false)
  virtual CmdResult scan(bool start) = 0;
  virtual CmdResult map_reset() = 0;
  virtual CmdResult localize() = 0;
  virtual CmdResult model_list(ConsoleWriter& out) = 0;
  //! 0 error .. 4 trace
  virtual CmdResult log_level(int level) = 0;
  //! A parameter was changed by `param set` (already range-checked and stored).
  virtual CmdResult param_changed(int id) = 0;
};

}  // namespace edgefuse::runtime
