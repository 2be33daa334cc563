#include "toml_util.hpp"

#include <cmath>

#include "edgefuse/hal/platform/config/toml_guard.hpp"
#include "file_util.hpp"

namespace edgefuse::io::detail {

bool parse_toml_file(const std::string& path, toml::table& out, std::string& err) {
  std::string text;
  if (!read_file(path, text, err)) return false;
  if (text.empty()) {
    err = path + ": empty file, expected TOML";
    return false;
  }
  if (const unsigned line = toml_non_ascii_line(text)) {  // toml++ 3.3.0's undefined behaviour (toml_guard.hpp)
    err = format("%s:%u: %s", path.c_str(), line, toml_non_ascii_reason());
    return false;
  }
  try {
    out = toml::parse(text, path);
  } catch (const toml::parse_error& e) {
    const auto& b = e.source().begin;
    err = format("%s:%u:%u: TOML syntax error: %.*s", path.c_str(), unsigned(b.line), unsigned(b.column),
                 int(e.description().size()), e.description().data());
    return false;
  }
  return true;
}

bool TomlFields::fail(const std::string& what) {
  err_ = where_ + ": " + what;
  return false;
}

std::string TomlFields::describe(const char* key) const {
  const toml::node* n = t_.get(key);
  std::string s = std::string("key '") + key + "'";
  if (n && n->source().begin.line) s += format(" (line %u)", unsigned(n->source().begin.line));
  return s;
}

namespace {
const char* type_name(const toml::node& n) {
  switch (n.type()) {
    case toml::node_type::string: return "a string";
    case toml::node_type::integer: return "an integer";
    case toml::node_type::floating_point: return "a float";
    case toml::node_type::boolean: return "a boolean";
    case toml::node_type::array: return "an array";
    case toml::node_type::table: return "a table";
    default: return "a date/time";
  }
}
}  // namespace

bool TomlFields::get_int(const char* key, long long& v, bool required, long long lo, long long hi) {
  const toml::node* n = t_.get(key);
  if (!n) return required ? fail(std::string("missing key '") + key + "'") : true;
  const auto* i = n->as_integer();
  if (!i) return fail(describe(key) + " must be an integer, got " + type_name(*n));
  const long long x = i->get();
  if (x < lo || x > hi) return fail(describe(key) + format(" must be in %lld..%lld, got %lld", lo, hi, x));
  v = x;
  return true;
}

bool TomlFields::get_number(const char* key, double& v, bool required, bool positive, bool non_negative) {
  const toml::node* n = t_.get(key);
  if (!n) return required ? fail(std::string("missing key '") + key + "'") : true;
  double x;
  if (const auto* i = n->as_integer()) {
    x = double(i->get());
  } else if (const auto* d = n->as_floating_point()) {
    x = d->get();
  } else {
    return fail(describe(key) + " must be a number, got " + type_name(*n));
  }
  // 1e30 keeps every value finite once stored as float.
  if (!std::isfinite(x) || std::fabs(x) > 1e30) return fail(describe(key) + format(" must be finite, got %g", x));
  if (positive && !(x > 0)) return fail(describe(key) + format(" must be > 0, got %g", x));
  if (non_negative && !(x >= 0)) return fail(describe(key) + format(" must be >= 0, got %g", x));
  v = x;
  return true;
}

bool TomlFields::get_bool(const char* key, bool& v, bool required) {
  const toml::node* n = t_.get(key);
  if (!n) return required ? fail(std::string("missing key '") + key + "'") : true;
  const auto* b = n->as_boolean();
  if (!b) return fail(describe(key) + " must be true or false, got " + type_name(*n));
  v = b->get();
  return true;
}

bool TomlFields::get_string(const char* key, std::string& v, bool required) {
  const toml::node* n = t_.get(key);
  if (!n) return required ? fail(std::string("missing key '") + key + "'") : true;
  const auto* s = n->as_string();
  if (!s) return fail(describe(key) + " must be a string, got " + type_name(*n));
  v = s->get();
  return true;
}

bool TomlFields::get_number_array(const char* key, std::vector<double>& v, bool required) {
  const toml::node* n = t_.get(key);
  if (!n) return required ? fail(std::string("missing key '") + key + "'") : true;
  const auto* a = n->as_array();
  if (!a) return fail(describe(key) + " must be an array of numbers, got " + type_name(*n));
  std::vector<double> out;
  for (std::size_t k = 0; k < a->size(); ++k) {
    const toml::node& e = *a->get(k);
    double x;
    if (const auto* i = e.as_integer()) {
      x = double(i->get());
    } else if (const auto* d = e.as_floating_point()) {
      x = d->get();
    } else {
      return fail(describe(key) + format(": element %zu must be a number, got ", k) + type_name(e));
    }
    if (!std::isfinite(x)) return fail(describe(key) + format(": element %zu must be finite, got %g", k, x));
    out.push_back(x);
  }
  v.swap(out);
  return true;
}

bool read_pinhole_fields(TomlFields& f, PinholeIntrinsics& intr, bool ranges_required, bool& has_min,
                         bool& has_max) {
  // 65535 bounds the image size far above any depth sensor while keeping width * height in range.
  long long w = 0, h = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0, scale = 0;
  if (!f.get_int("width", w, true, 1, 65535) || !f.get_int("height", h, true, 1, 65535) ||
      !f.get_number("fx", fx, true, true) || !f.get_number("fy", fy, true, true) ||
      !f.get_number("cx", cx, true) || !f.get_number("cy", cy, true) ||
      !f.get_number("depth_scale", scale, true, true))
    return false;
  PinholeIntrinsics out;
  out.width = int(w);
  out.height = int(h);
  out.fx = float(fx);
  out.fy = float(fy);
  out.cx = float(cx);
  out.cy = float(cy);
  out.depth_scale = float(scale);
  has_min = f.has("min_range");
  has_max = f.has("max_range");
  double mn = out.min_range_m, mx = out.max_range_m;
  if (!f.get_number("min_range", mn, ranges_required, false, true) || !f.get_number("max_range", mx, ranges_required, true))
    return false;
  if (!(mn < mx))
    return f.fail(format("min_range (%g) must be < max_range (%g)", mn, mx));
  out.min_range_m = float(mn);
  out.max_range_m = float(mx);
  if (!(scale <= PinholeIntrinsics::kMaxDepthScale))
    return f.fail(format("depth_scale must be at most %g raw units per metre (a 1 um unit), got %g",
                         double(PinholeIntrinsics::kMaxDepthScale), scale));
  if (out.validate() != Status::kOk)  // float overflow of huge values, or numbers no camera has
    return f.fail(format("fx, fy, cx, cy must lie within %g pixels (%g x the larger image size): got %g, %g, %g, %g",
                         double(out.max_pixel_coordinate()),
                         double(PinholeIntrinsics::kMaxPixelsPerSize), fx, fy, cx, cy));
  intr = out;
  return true;
}

bool table_array(const std::string& path, const toml::table& t, const char* key, const toml::array*& arr,
                 std::string& err) {
  arr = nullptr;
  const toml::node* n = t.get(key);
  if (!n) return true;
  arr = n->as_array();
  if (!arr || !arr->is_array_of_tables()) {
    err = path + ": '" + key + "' must be an array of tables ([[" + key + "]])";
    return false;
  }
  return true;
}

std::string table_where(const std::string& path, const char* kind, std::size_t index, const toml::table& t) {
  std::string w = path + ": [[" + kind + "]] #" + std::to_string(index + 1);
  if (t.source().begin.line) w += " (line " + std::to_string(unsigned(t.source().begin.line)) + ")";
  return w;
}

}  // namespace edgefuse::io::detail
