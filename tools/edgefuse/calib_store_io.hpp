// `edgefuse calibrate --store DIR`: puts a calibrated T_A_B into the on-board calibration store
// (hal/platform/config CalibFileStore: two CRC-checked slots, atomic save), keeping everything else the
// newest valid slot holds (other pairs, intrinsic overrides, hand-eye, bin pose).
#pragma once

#include <string>

#include "edgefuse/math/pose.hpp"

namespace edgefuse::cli {

//! Loads the newest valid slot of the store in `dir` (an empty table when there is none), sets the
//! pair (from, to) to T_from_to and saves it into the other slot.
//! \param dir folder of the slot files (created on the first save)
//! \param from sensor A (rig.toml name)  \param to sensor B  \param T_from_to pose of B in A's frame
//! \param message one line: what was loaded and which slot / sequence number was written
//! \param err names the store, the slot file or the failed step
bool store_calibrated_pair(const std::string& dir, const std::string& from, const std::string& to,
                           const Pose& T_from_to, std::string& message, std::string& err);

//! The sensor's mounting on the robot flange from the newest valid slot of the store in `dir`, as
//! edgefused composes it: T_flange_sensor = T_flange_rig (hand-eye, HANDEYE SAVE) * T_rig_sensor
//! (the pair ("rig", sensor) when stored, else the identity: the rig is that sensor).
//! \param what one line: the slot read and where each part came from
//! \return false (err set) when no slot is valid or no hand-eye is stored (the identity default)
bool load_flange_mounting(const std::string& dir, const std::string& sensor, Pose& T_flange_sensor, std::string& what,
                          std::string& err);

}  // namespace edgefuse::cli
