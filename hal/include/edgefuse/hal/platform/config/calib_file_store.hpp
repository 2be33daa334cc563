// The calibration store on the board's file system: two slot files (calib_a.bin, calib_b.bin) in
// one folder. A save goes to the slot that does not hold the newest good calibration, with the
// next sequence number, written atomically: temporary file, write, fsync, close, rename over the
// slot, fsync of the folder. A power cut at any step leaves the other slot (the last good
// calibration) untouched; loading takes the newest valid slot and reports a corrupt one.
#pragma once

#include <cstdint>
#include <string>

#include "edgefuse/runtime/calibration.hpp"

namespace edgefuse::hal {

//! The steps of a save, in order (for the failure-injection hook of the tests).
enum class SaveStep { kOpenTemp, kWriteFirstHalf, kWriteSecondHalf, kFsyncFile, kClose, kRename, kFsyncDir };
constexpr int kSaveStepCount = 7;
const char* to_string(SaveStep s);

//! What loading found.
struct CalibLoadReport {
  int slot = -1;                     //!< slot loaded (0 = a, 1 = b), -1 if none is valid
  uint32_t seq = 0;                  //!< its sequence number
  runtime::SlotStatus status[2] = {runtime::SlotStatus::kMissing, runtime::SlotStatus::kMissing};
  std::string message;               //!< one line for the log: what was loaded, what was corrupt
};

class CalibFileStore {
 public:
  //! Called before each step; returning false makes the step fail as an I/O error would.
  using StepHook = bool (*)(SaveStep step, void* ctx);

  //! \param dir folder of the slots (created on the first save)
  explicit CalibFileStore(std::string dir) : dir_(std::move(dir)) {}

  //! Loads the newest valid slot.
  //! \param d   filled when a valid slot exists (left unchanged otherwise)
  //! \param rep what was found
  //! \return true if a valid slot was loaded
  bool load(runtime::CalibrationData& d, CalibLoadReport& rep) const;

  //! Saves into the other slot with the next sequence number.
  //! \param d    the data
  //! \param err  names the file and the failed step
  bool save(const runtime::CalibrationData& d, std::string& err);

  std::string slot_path(int slot) const;
  void set_step_hook(StepHook hook, void* ctx) {
    hook_ = hook;
    hook_ctx_ = ctx;
  }

 private:
  std::string dir_;
  StepHook hook_ = nullptr;
  void* hook_ctx_ = nullptr;
};

}  // namespace edgefuse::hal
