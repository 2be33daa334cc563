// PCD v0.7 header model and parser.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace edgefuse::io::detail {

struct PcdField {
  std::string name;
  int size = 4;      //!< bytes per element: 1, 2, 4 or 8
  char type = 'F';   //!< 'I' signed, 'U' unsigned, 'F' float (size 4 or 8)
  uint32_t count = 1;
  std::size_t offset = 0;  //!< byte offset inside a point record (binary layout)
  std::size_t bytes() const { return std::size_t(size) * count; }
};

enum class PcdData { kAscii, kBinary, kBinaryCompressed };

struct PcdHeader {
  std::vector<PcdField> fields;
  uint64_t width = 0, height = 1, points = 0;
  PcdData data = PcdData::kAscii;
  std::size_t point_size = 0;   //!< bytes per point record
  std::size_t data_offset = 0;  //!< first byte after the DATA line
  int find(const char* name) const;
};

//! Parses and checks the header: SIZE/TYPE/COUNT agree with FIELDS and are valid, POINTS (when
//! given) equals WIDTH * HEIGHT, DATA is ascii, binary or binary_compressed and ends the header.
bool parse_pcd_header(const std::string& path, std::string_view data, PcdHeader& header, std::string& err);

}  // namespace edgefuse::io::detail
