#include "ply_header.hpp"

#include "file_util.hpp"
#include "text_util.hpp"

namespace edgefuse::io::detail {

int ply_type_size(PlyType t) {
  switch (t) {
    case PlyType::kInt8:
    case PlyType::kUint8: return 1;
    case PlyType::kInt16:
    case PlyType::kUint16: return 2;
    case PlyType::kInt32:
    case PlyType::kUint32:
    case PlyType::kFloat32: return 4;
    case PlyType::kFloat64: return 8;
  }
  return 1;
}

bool ply_type_is_integer(PlyType t) { return t != PlyType::kFloat32 && t != PlyType::kFloat64; }

int PlyElement::find(const char* prop_name) const {
  for (std::size_t i = 0; i < props.size(); ++i)
    if (props[i].name == prop_name) return int(i);
  return -1;
}

namespace {
bool type_from_name(std::string_view n, PlyType& t) {
  struct Name {
    const char* a;
    const char* b;
    PlyType t;
  };
  static const Name names[] = {{"char", "int8", PlyType::kInt8},       {"uchar", "uint8", PlyType::kUint8},
                               {"short", "int16", PlyType::kInt16},    {"ushort", "uint16", PlyType::kUint16},
                               {"int", "int32", PlyType::kInt32},      {"uint", "uint32", PlyType::kUint32},
                               {"float", "float32", PlyType::kFloat32}, {"double", "float64", PlyType::kFloat64}};
  for (const Name& x : names)
    if (n == x.a || n == x.b) {
      t = x.t;
      return true;
    }
  return false;
}
}  // namespace

bool parse_ply_header(const std::string& path, std::string_view data, PlyHeader& header, std::string& err) {
  if (data.empty()) {
    err = path + ": empty file, expected a PLY file";
    return false;
  }
  LineReader lines(data);
  std::string_view line;
  if (!lines.next(line) || trim(line) != "ply") {
    err = path + ": not a PLY file (first line is not 'ply')";
    return false;
  }
  PlyHeader h;
  bool have_format = false;
  std::vector<std::string_view> tok;
  while (lines.next(line)) {
    split_ws(line, tok);
    const int ln = lines.line_number();
    if (tok.empty() || tok[0] == "comment" || tok[0] == "obj_info") continue;
    if (tok[0] == "end_header") {
      if (!have_format) {
        err = path + ": PLY header has no 'format' line";
        return false;
      }
      h.data_offset = std::size_t(lines.position() - data.data());
      header = std::move(h);
      return true;
    }
    if (tok[0] == "format") {
      if (tok.size() != 3) {
        err = format("%s:%d: expected 'format <encoding> 1.0'", path.c_str(), ln);
        return false;
      }
      if (tok[1] == "ascii") {
        h.ascii = true;
      } else if (tok[1] == "binary_little_endian") {
        h.ascii = false;
      } else {
        err = format("%s:%d: unsupported PLY format %s (ascii and binary_little_endian are read)", path.c_str(), ln,
                     quote(tok[1]).c_str());
        return false;
      }
      have_format = true;
    } else if (tok[0] == "element") {
      PlyElement e;
      if (tok.size() != 3 || !parse_uint64(tok[2], e.count)) {
        err = format("%s:%d: expected 'element <name> <count>' with a count >= 0", path.c_str(), ln);
        return false;
      }
      e.name = std::string(tok[1]);
      for (const PlyElement& o : h.elements)
        if (o.name == e.name) {
          err = format("%s:%d: element '%s' declared twice", path.c_str(), ln, e.name.c_str());
          return false;
        }
      h.elements.push_back(std::move(e));
    } else if (tok[0] == "property") {
      if (h.elements.empty()) {
        err = format("%s:%d: property before any element", path.c_str(), ln);
        return false;
      }
      PlyProperty p;
      if (tok.size() == 3 && type_from_name(tok[1], p.type)) {
        p.name = std::string(tok[2]);
      } else if (tok.size() == 5 && tok[1] == "list" && type_from_name(tok[2], p.count_type) &&
                 type_from_name(tok[3], p.type)) {
        if (!ply_type_is_integer(p.count_type)) {
          err = format("%s:%d: list count type must be an integer type", path.c_str(), ln);
          return false;
        }
        p.is_list = true;
        p.name = std::string(tok[4]);
      } else {
        err = format("%s:%d: bad property line %s", path.c_str(), ln, quote(trim(line)).c_str());
        return false;
      }
      h.elements.back().props.push_back(std::move(p));
    } else {
      err = format("%s:%d: unexpected PLY header line %s", path.c_str(), ln, quote(trim(line)).c_str());
      return false;
    }
  }
  err = path + ": PLY header has no end_header line (truncated?)";
  return false;
}

}  // namespace edgefuse::io::detail
