// PLY (Stanford polygon format) points and meshes: ascii and binary_little_endian.
//
// Read: element "vertex" with x y z [nx ny nz] [red green blue [alpha]] [label] of any scalar type;
// element "face" with a list property vertex_indices/vertex_index (count uchar/uint8/..., index
// int/uint/int32/uint32/...), polygons fan-triangulated. Every other element and property is
// skipped by its declared type. Counts are checked against the file size before allocating.
#pragma once

#include <string>

#include "edgefuse/io/cloud.hpp"

namespace edgefuse::io {

enum class PlyEncoding { kBinaryLittleEndian, kAscii };

//! Vertices only (faces are parsed for validity, then dropped). width = points, height = 1.
bool read_ply(const std::string& path, PointCloud& cloud, std::string& err);
//! Vertices and triangles (no face element: an empty triangle list).
bool read_ply(const std::string& path, TriangleMesh& mesh, std::string& err);

//! Writes "x y z [nx ny nz] [red green blue alpha] [label]" as float / uchar / uint. Attribute
//! vectors must be empty or match the point count. NaN points are written as they are.
bool write_ply(const std::string& path, const PointCloud& cloud, std::string& err,
               PlyEncoding enc = PlyEncoding::kBinaryLittleEndian);
//! Writes vertices (with normals/colours when present) and "list uchar uint vertex_indices" faces.
bool write_ply(const std::string& path, const TriangleMesh& mesh, std::string& err,
               PlyEncoding enc = PlyEncoding::kBinaryLittleEndian);

}  // namespace edgefuse::io
