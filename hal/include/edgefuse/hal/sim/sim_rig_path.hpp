// The sim rig moving along key poses instead of its circle (edgefused's sensors.sim_path): a
// TUM-format file, one key a line, `stamp tx ty tz qx qy qz qw` = the rig (reference camera) pose
// in the sim world at `stamp` seconds (m, unit quaternion; `#` comments and blank lines skipped).
// The first key is at the rig's motion start, later stamps are relative to it and increase.
// Between two keys the rig moves by lerp (translation) and slerp (rotation) with a smoothstep
// easing, so it leaves and reaches every key at rest (a robot's move, and no velocity jump for
// ICP); two consecutive keys with the same pose hold it still: a station. Before the first key the
// rig is at the first, after the last at the last.
// Why a file: hand-eye calibration needs rotations about >= 2 non-parallel axes, which the
// circle (translation only) never offers; the simulated robot (tools/robot/robot_sim.py
// --handeye) reads the same file to know the flange's path.
// Static capacity: kSimRigPathKeysMax keys (32 held stations, an arrival and a departure each).
#pragma once

#include <string>

#include "edgefuse/math/pose.hpp"

namespace edgefuse::hal {

inline constexpr int kSimRigPathKeysMax = 64;

struct SimRigPath {
  int count = 0;                          //!< keys in use
  double stamp_s[kSimRigPathKeysMax] = {};  //!< key times since the first key
  Pose pose[kSimRigPathKeysMax];          //!< T_world_rig at each key

  //! The rig's pose at a time on the path (held before the first and after the last key).
  //! \param t_s seconds since the rig's motion started (the first key)
  Pose at(double t_s) const;
  //! Seconds from the first key to the last (0 without keys).
  double duration_s() const { return count > 0 ? stamp_s[count - 1] : 0.0; }
};

//! Reads a key-pose file (see the file comment) into `out`.
//! \param file the TUM-format file
//! \param out receives the keys (count 0 on failure)
//! \param err on failure: the file, the line and what is wrong with it
//! \return false for a missing file, a malformed line, a stamp not after the previous one, a
//!         zero quaternion, more than kSimRigPathKeysMax keys or no key at all
bool load_sim_rig_path(const std::string& file, SimRigPath& out, std::string& err);

}  // namespace edgefuse::hal
