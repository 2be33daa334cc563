// rig.toml (FORMATS.md section 4).
#include "edgefuse/io/rig.hpp"

#include <exception>
#include <new>

#include "file_util.hpp"
#include "toml_util.hpp"

namespace edgefuse::io {

using detail::format;

const RigSensor* RigToml::find_sensor(const std::string& n) const {
  for (const RigSensor& s : sensors)
    if (s.name == n) return &s;
  return nullptr;
}

const RigObject* RigToml::find_object(int id) const {
  for (const RigObject& o : objects)
    if (o.id == id) return &o;
  return nullptr;
}

namespace {

// The name is used as a folder name: keep it to one plain path component.
bool folder_safe(const std::string& n) {
  if (n.empty() || n == "." || n == "..") return false;
  for (char c : n)
    if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-' ||
          c == '.'))
      return false;
  return true;
}

bool read_sensor(const std::string& path, std::size_t index, const toml::table& t, RigSensor& s, std::string& err) {
  detail::TomlFields f(t, detail::table_where(path, "sensor", index, t), err);
  if (!f.get_string("name", s.name, true)) return false;
  if (!folder_safe(s.name))
    return f.fail("name '" + s.name + "' must be a plain folder name (letters, digits, '_', '-', '.')");
  // From here on the sensor's name identifies it in messages.
  detail::TomlFields g(t, format("%s: sensor '%s'", path.c_str(), s.name.c_str()) +
                              (t.source().begin.line ? format(" (line %u)", unsigned(t.source().begin.line)) : ""),
                       err);
  std::string kind;
  if (!g.get_string("kind", kind, true)) return false;
  if (kind == "pinhole") {
    s.kind = SensorKind::kPinhole;
    bool has_min = false, has_max = false;
    if (!detail::read_pinhole_fields(g, s.pinhole, false, has_min, has_max)) return false;
    return g.get_bool("color", s.color, false) && g.get_bool("amplitude", s.amplitude, false);
  }
  if (kind == "line_scanner") {
    s.kind = SensorKind::kLineScanner;
    long long beams = 0;
    double fov = 0, mn = 0, mx = 0;
    if (!g.get_int("beams", beams, true, 2, 65536) || !g.get_number("fov_deg", fov, true, true) ||
        !g.get_number("min_range", mn, true, false, true) || !g.get_number("max_range", mx, true, true))
      return false;
    if (!(fov < 360)) return g.fail(format("key 'fov_deg' must be < 360, got %g", fov));
    if (!(mn < mx)) return g.fail(format("min_range (%g) must be < max_range (%g)", mn, mx));
    s.line.beams = int(beams);
    s.line.fov_deg = float(fov);
    s.line.min_range_m = float(mn);
    s.line.max_range_m = float(mx);
    return true;
  }
  return g.fail("kind must be \"pinhole\" or \"line_scanner\", got \"" + kind + "\"");
}

bool read_object(const std::string& root, const std::string& path, std::size_t index, const toml::table& t,
                 RigObject& o, std::string& err) {
  detail::TomlFields f(t, detail::table_where(path, "object", index, t), err);
  long long id = 0;
  if (!f.get_int("id", id, true, 0, 2147483647) || !f.get_string("model", o.model, true)) return false;
  if (o.model.empty() || o.model[0] == '/')
    return f.fail("model must be a path relative to the rig folder, got '" + o.model + "'");
  o.id = int(id);
  o.model_path = detail::join_path(root, o.model);
  return true;
}

}  // namespace

bool read_rig_toml(const std::string& path, RigToml& rig, std::string& err) {
  return detail::guarded(path, err, [&] {
    toml::table t;
    if (!detail::parse_toml_file(path, t, err)) return false;
    RigToml out;
    out.root = detail::parent_dir(path);
    detail::TomlFields top(t, path, err);
    if (!top.get_string("name", out.name, false)) return false;
    const toml::array* sensors = nullptr;
    const toml::array* objects = nullptr;
    if (!detail::table_array(path, t, "sensor", sensors, err) || !detail::table_array(path, t, "object", objects, err))
      return false;
    if (!sensors || sensors->empty()) return top.fail("no [[sensor]] tables");
    for (std::size_t i = 0; i < sensors->size(); ++i) {
      RigSensor s;
      if (!read_sensor(path, i, *sensors->get(i)->as_table(), s, err)) return false;
      if (out.find_sensor(s.name)) return top.fail("sensor name '" + s.name + "' is used twice");
      out.sensors.push_back(s);
    }
    for (std::size_t i = 0; objects && i < objects->size(); ++i) {
      RigObject o;
      if (!read_object(out.root, path, i, *objects->get(i)->as_table(), o, err)) return false;
      if (out.find_object(o.id)) return top.fail(format("object id %d is used twice", o.id));
      out.objects.push_back(o);
    }
    rig = out;
    return true;
  });
}

}  // namespace edgefuse::io
