// TUM trajectories ("timestamp tx ty tz qx qy qz qw", sensor-to-world) and timestamp association.
#pragma once

#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "edgefuse/math/pose.hpp"

namespace edgefuse::io {

struct StampedPose {
  double stamp_s = 0;  //!< seconds (double: TUM stamps are ~1.3e9 with microseconds)
  Pose T;              //!< T_world_sensor
};

//! Reads a TUM trajectory: '#' comments and blank lines skipped, 8 numbers per line, quaternion of
//! unit norm (within 1 %), returned sorted by time. Errors name the file and line.
bool read_tum_trajectory(const std::string& path, std::vector<StampedPose>& poses, std::string& err);

//! Writes "timestamp tx ty tz qx qy qz qw" lines (quaternion with qw >= 0) after a '#' header.
bool write_tum_trajectory(const std::string& path, const std::vector<StampedPose>& poses, std::string& err,
                          const std::string& comment = std::string());

//! The pose whose stamp is nearest to `stamp_s` if it is less than `max_dt_s` away, else nullptr.
//! `poses` must be sorted by stamp (as read_tum_trajectory returns them).
const StampedPose* find_nearest(const std::vector<StampedPose>& poses, double stamp_s, double max_dt_s = 0.02);

//! Index of the nearest stamp in sorted `stamps` closer than max_dt_s, or -1.
long find_nearest_stamp(const std::vector<double>& stamps, double stamp_s, double max_dt_s = 0.02);

//! TUM associate.py: all pairs closer than max_dt_s, taken greedily by increasing difference, each
//! stamp used at most once. Returns for every entry of `a` the index into `b`, or -1.
std::vector<long> associate_stamps(const std::vector<double>& a, const std::vector<double>& b,
                                   double max_dt_s = 0.02);

//! A 4x4 row-major camera-to-world matrix file (7-Scenes frame-NNNNNN.pose.txt): last row 0 0 0 1,
//! finite, rotation orthonormal within 1e-3.
bool read_pose_matrix_txt(const std::string& path, Pose& T, std::string& err);

}  // namespace edgefuse::io
