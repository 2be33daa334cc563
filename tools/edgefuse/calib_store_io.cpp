#include "calib_store_io.hpp"


#include "edgefuse/hal/platform/config/calib_file_store.hpp"
#include "edgefuse/runtime/calib_pose.hpp"
#include "edgefuse/runtime/calibration.hpp"

namespace edgefuse::cli {

bool store_calibrated_pair(const std::string& dir, const std::string& from, const std::string& to,
                           const Pose& T_from_to, std::string& message, std::string& err) {
  if (from.size() > runtime::kSensorNameMax || to.size() > runtime::kSensorNameMax) {
    err = "--store " + dir + ": sensor names longer than " + std::to_string(runtime::kSensorNameMax) +
          " characters do not fit the calibration store";
    return false;
  }
  hal::CalibFileStore store(dir);
  runtime::CalibrationData data;
  hal::CalibLoadReport rep;
  // A store whose both slots are corrupt is not overwritten blindly: the other entries would be
  // lost without anyone noticing. Missing slots (a new store) are fine.
  if (!store.load(data, rep)) {
    for (int s = 0; s < 2; ++s)
      if (rep.status[s] != runtime::SlotStatus::kMissing) {
        err = "--store " + dir + ": " + store.slot_path(s) + " is " + runtime::to_string(rep.status[s]) +
              " and no slot is valid; not overwriting it (move the folder away to start a new store)";
        return false;
      }
    data = runtime::CalibrationData();
  }
  // The store's layout: translation (m) and unit quaternion x y z w (w >= 0), as extrinsics.txt.
  runtime::CalibPose p;
  const Eigen::Quaternionf q = T_from_to.quaternion();
  const float tq[7] = {T_from_to.t.x(), T_from_to.t.y(), T_from_to.t.z(), q.x(), q.y(), q.z(), q.w()};
  for (int k = 0; k < 7; ++k) p.tq[k] = tq[k];
  if (!runtime::calib_set_pair(data, from.c_str(), to.c_str(), p)) {
    err = "--store " + dir + ": the calibration table is full (" + std::to_string(runtime::kCalibPairsMax) + " pairs)";
    return false;
  }
  if (!store.save(data, err)) {
    err = "--store " + dir + ": " + err;
    return false;
  }
  hal::CalibLoadReport after;
  runtime::CalibrationData check;
  if (!store.load(check, after) || runtime::calib_find_pair(check, from.c_str(), to.c_str()) == nullptr) {
    err = "--store " + dir + ": the saved calibration does not read back (" + after.message + ")";
    return false;
  }
  message = "stored T_" + from + "_" + to + " in " + store.slot_path(after.slot) + " (seq " + std::to_string(after.seq) +
            "; " + (rep.slot < 0 ? std::string("new store") : "kept the other entries of seq " + std::to_string(rep.seq)) +
            ")";
  return true;
}

bool load_flange_mounting(const std::string& dir, const std::string& sensor, Pose& T_flange_sensor, std::string& what,
                          std::string& err) {
  hal::CalibFileStore store(dir);
  runtime::CalibrationData data;
  hal::CalibLoadReport rep;
  if (!store.load(data, rep)) {
    err = "calibration store " + dir + ": no valid slot (" + rep.message + ")";
    return false;
  }
  if (runtime::is_default(data.T_flange_rig)) {
    err = "calibration store " + dir + ": no hand-eye calibration stored (T_flange_rig is the identity default)";
    return false;
  }
  Pose T_rig_sensor = Pose::identity();
  const bool mounted = runtime::rig_mounting(data, sensor.c_str(), T_rig_sensor);
  T_flange_sensor = runtime::to_pose(data.T_flange_rig) * T_rig_sensor;
  what = "calibration store " + store.slot_path(rep.slot) + " (seq " + std::to_string(rep.seq) + "): T_flange_rig" +
         (mounted ? " x T_rig_" + sensor : " (the rig is " + sensor + ")");
  return true;
}

}  // namespace edgefuse::cli
