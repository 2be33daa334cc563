// PLY header model and parser (shared by the reader; the writer emits headers directly).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace edgefuse::io::detail {

enum class PlyType { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };

int ply_type_size(PlyType t);
bool ply_type_is_integer(PlyType t);

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::kFloat32;  //!< the item type for lists
  bool is_list = false;
  PlyType count_type = PlyType::kUint8;  //!< lists only
};

struct PlyElement {
  std::string name;
  uint64_t count = 0;
  std::vector<PlyProperty> props;
  int find(const char* prop_name) const;  //!< property index or -1
};

struct PlyHeader {
  bool ascii = false;  //!< else binary_little_endian
  std::vector<PlyElement> elements;
  std::size_t data_offset = 0;  //!< first byte after "end_header\n"
};

//! Parses the header of `data` (the whole file). Rejects binary_big_endian, unknown types,
//! properties outside an element, list counts of non-integer type, and a missing end_header.
bool parse_ply_header(const std::string& path, std::string_view data, PlyHeader& header, std::string& err);

}  // namespace edgefuse::io::detail
