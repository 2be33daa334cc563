// PCL's PCD v0.7 point clouds: ascii, binary and binary_compressed (LZF, column-wise).
//
// Read: fields x y z (required), normal_x normal_y normal_z, rgb/rgba (packed 4-byte float or uint),
// label; any other field (curvature, "_" padding, ...) is skipped by its SIZE/TYPE/COUNT. The
// organisation (WIDTH x HEIGHT) and NaN points are kept. Every count and size in the header is
// checked against the file size before anything is allocated.
#pragma once

#include <string>

#include "edgefuse/io/cloud.hpp"

namespace edgefuse::io {

enum class PcdEncoding { kBinary, kAscii, kBinaryCompressed };

bool read_pcd(const std::string& path, PointCloud& cloud, std::string& err);

//! Writes FIELDS x y z [normal_x normal_y normal_z] [rgba] [label] (float, float, uint32 0xAARRGGBB,
//! uint32). rgba rather than rgb keeps the "never seen in colour" alpha and is what PCL's
//! PointXYZRGBA and Open3D read. width * height must equal the point count (width 0: unorganised).
bool write_pcd(const std::string& path, const PointCloud& cloud, std::string& err,
               PcdEncoding enc = PcdEncoding::kBinary);

}  // namespace edgefuse::io
