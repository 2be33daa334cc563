// The reference camera's last two poses and the pose at any nearby capture stamp. Another camera
// of the rig, paired with a reference frame within kPairWindowUs, is placed at the reference's pose
// at its own stamp times its extrinsics: a rig moving at 0.25 m/s moves 8 mm between two 30 fps
// frames, so the nearest reference frame alone would misplace it by up to 10 mm.
#pragma once

#include <cstdint>

#include "edgefuse/math/pose.hpp"

namespace edgefuse {

class PoseHistory {
 public:
  //! Largest stamp difference between a camera's frame and the reference frame whose pose it takes.
  static constexpr uint64_t kPairWindowUs = 40000;
  //! Gaps between the reference's last two frames that give a velocity: at least 10 ms (a 100 fps
  //! camera; closer stamps would magnify pose noise into the velocity) and at most 250 ms. A board
  //! steps slower than its camera when loaded (the newest frame is taken): at load 9 on 2 cores the
  //! host steps every 100-200 ms. The constant-velocity error a t_e (t_e + g) / 2 stays below the
  //! last pose's v t_e while g < 2 v / a - t_e: for a robot at v = 0.25 m/s accelerating at
  //! a = 1 m/s^2 and the 40 ms window, g < 460 ms; at 250 ms the velocity's 5.8 mm against 10 mm
  //! still pays. A longer gap, a lost frame or a new map leaves only the last pose.
  static constexpr uint64_t kVelocityGapMinUs = 10000;
  static constexpr uint64_t kVelocityGapMaxUs = 250000;

  //! Forgets every pose (a new map).
  void clear() {
    have_pose_ = false;
    have_velocity_ = false;
  }
  //! Records the reference's frame: its pose, or none (a lost or unplaced frame).
  //! \param stamp_us the frame's capture stamp  \param T_world_ref its pose  \param placed it has one
  void record(uint64_t stamp_us, const Pose& T_world_ref, bool placed);
  //! The pose at capture time stamp_us: on the constant-velocity path through the last two poses
  //! (interpolated between them, extrapolated by at most kPairWindowUs beyond either), or the last
  //! pose when there is no such pair.
  Pose pose_at(uint64_t stamp_us) const;
  bool has_pose() const { return have_pose_; }          //!< the last frame had a pose
  bool has_velocity() const { return have_velocity_; }  //!< pose_at() interpolates
  uint64_t stamp_us() const { return stamp_us_; }       //!< the last frame's stamp (0 before any)
  const Pose& last() const { return pose_; }

 private:
  bool have_pose_ = false;
  bool have_velocity_ = false;
  Pose pose_, prev_pose_;
  uint64_t stamp_us_ = 0, prev_stamp_us_ = 0;
};

//! The robot's flange poses as streamed over the link (T_base_flange with the board-clock stamp of
//! each), newest last, in a fixed ring: kCapacity covers 2 s at the link's 250 Hz, more than any
//! latency offset between a frame and the robot's pose (the tracking looks a pose up by the frame's
//! stamp). Stamps must increase: an older or equal stamp is refused (counted), so a late packet
//! cannot fold the path back. No heap.
class StampedPoseHistory {
 public:
  static constexpr int kCapacity = 512;

  //! Appends a pose. \param stamp_us its time (board clock)  \param T_base_flange the pose
  //! \return false (counted in refused()) when stamp_us is not newer than the last one
  bool record(uint64_t stamp_us, const Pose& T_base_flange);
  //! The pose at stamp_us, interpolated between the two recorded poses around it (at constant
  //! velocity, as interpolate()). \param stamp_us the time  \param T_base_flange set on success
  //! \return false when stamp_us lies outside the recorded span (older than the oldest pose kept,
  //!         newer than the newest)
  bool pose_at(uint64_t stamp_us, Pose& T_base_flange) const;
  void clear() {
    count_ = 0;
    head_ = 0;
  }
  int size() const { return count_; }                     //!< poses held
  uint32_t recorded() const { return recorded_; }        //!< poses accepted since start
  uint32_t refused() const { return refused_; }          //!< poses refused (stamp not increasing)
  //! The newest pose. \param stamp_us its stamp \return false when empty
  bool newest(Pose& T_base_flange, uint64_t& stamp_us) const;

 private:
  struct Entry {
    uint64_t stamp_us = 0;
    Pose T_base_flange;
  };
  const Entry& at(int i) const { return ring_[(head_ + kCapacity - count_ + i) % kCapacity]; }  // 0 = oldest
  Entry ring_[kCapacity];
  int head_ = 0;   // where the next pose goes
  int count_ = 0;
  uint32_t recorded_ = 0;
  uint32_t refused_ = 0;
};

}  // namespace edgefuse
