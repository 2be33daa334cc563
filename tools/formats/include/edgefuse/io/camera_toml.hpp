// camera.toml: intrinsics of a single-sensor folder (FORMATS.md section 5).
#pragma once

#include <string>
#include <vector>

#include "edgefuse/sensor/pinhole.hpp"

namespace edgefuse::io {

//! Lens distortion as published (OpenCV order k1 k2 p1 p2 k3 [k4 k5 k6 ...]). The core models an
//! ideal pinhole and ignores it; tools may undistort with it.
struct CameraDistortion {
  std::vector<double> coeffs;  //!< empty: none given
};

struct CameraToml {
  PinholeIntrinsics intr;
  CameraDistortion distortion;
  bool has_min_range = false;  //!< min_range was in the file (else the PinholeIntrinsics default)
  bool has_max_range = false;
};

//! Parses and range-checks camera.toml: kind = "pinhole" (optional), width/height integers > 0,
//! fx/fy > 0, cx/cy finite, depth_scale > 0, optional 0 <= min_range < max_range, optional
//! distortion array of 4, 5, 8, 12 or 14 finite numbers. Messages name the file, the key and value.
bool read_camera_toml(const std::string& path, CameraToml& cam, std::string& err);
bool read_camera_toml(const std::string& path, PinholeIntrinsics& intr, std::string& err);

//! Writes a camera.toml that read_camera_toml reads back.
bool write_camera_toml(const std::string& path, const CameraToml& cam, std::string& err);

//! camera-intrinsics.txt of the per-frame layout: a 3x3 K, row-major (last row 0 0 1, no skew).
bool read_intrinsics_matrix_txt(const std::string& path, float& fx, float& fy, float& cx, float& cy,
                                std::string& err);

}  // namespace edgefuse::io
