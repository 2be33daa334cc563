#include "edgefuse/io/board_hal.hpp"

#include <cstdio>

#include "file_util.hpp"
#include "toml_util.hpp"

namespace edgefuse::io {

const BoardPin* BoardHal::find_pin(const std::string& name) const {
  for (const BoardPin& p : pins)
    if (p.name == name) return &p;
  return nullptr;
}

namespace {

// A string key that must be one of `names`; its index in `out`.
bool get_choice(detail::TomlFields& f, const char* key, const char* const* names, int count, int& out,
                bool required) {
  std::string v;
  if (!f.get_string(key, v, required)) return false;
  if (v.empty() && !required) return true;
  for (int i = 0; i < count; ++i)
    if (v == names[i]) {
      out = i;
      return true;
    }
  std::string list;
  for (int i = 0; i < count; ++i) list += std::string(i ? ", " : "") + names[i];
  return f.fail(std::string(key) + " = '" + v + "' is not one of " + list);
}

bool get_name(detail::TomlFields& f, std::string& name) {
  if (!f.get_string("name", name, true)) return false;
  if (name.empty() || name.size() > 31) return f.fail("name must have 1..31 characters");
  return true;
}

}  // namespace

bool read_board_hal(const std::string& path, BoardHal& hal, std::string& err) {
  static const char* const kCameraBackends[] = {"sim", "replay", "openni2", "v4l2", "null"};
  static const char* const kScannerBackends[] = {"sim", "replay", "null"};
  static const char* const kDirections[] = {"input", "output"};
  static const char* const kEdges[] = {"rising", "falling", "both"};
  return detail::guarded(path, err, [&] {
    toml::table t;
    if (!detail::parse_toml_file(path, t, err)) return false;
    BoardHal out;
    detail::TomlFields top(t, path, err);
    const toml::array *cams = nullptr, *scanners = nullptr, *pins = nullptr;
    if (!detail::table_array(path, t, "camera", cams, err) ||
        !detail::table_array(path, t, "line_scanner", scanners, err) || !detail::table_array(path, t, "pin", pins, err))
      return false;
    for (std::size_t i = 0; pins && i < pins->size(); ++i) {
      const toml::table& pt = *pins->get(i)->as_table();
      detail::TomlFields f(pt, detail::table_where(path, "pin", i, pt), err);
      BoardPin p;
      long long offset = 0, debounce = 0;
      int dir = 0, edge = 0;
      if (!get_name(f, p.name) || !f.get_string("chip", p.chip, true) ||
          !f.get_int("offset", offset, true, 0, 1023) || !get_choice(f, "direction", kDirections, 2, dir, true) ||
          !get_choice(f, "edge", kEdges, 3, edge, false) || !f.get_int("debounce_us", debounce, false, 0, 1000000))
        return false;
      if (p.chip.empty()) return f.fail("chip must not be empty");
      p.offset = int(offset);
      p.direction = PinDirection(dir);
      p.edge = PinEdge(edge);
      p.debounce_us = int(debounce);
      if (out.find_pin(p.name)) return top.fail("pin name '" + p.name + "' is used twice");
      out.pins.push_back(p);
    }
    for (std::size_t i = 0; cams && i < cams->size(); ++i) {
      const toml::table& ct = *cams->get(i)->as_table();
      detail::TomlFields f(ct, detail::table_where(path, "camera", i, ct), err);
      BoardCamera c;
      int backend = 0;
      long long w = 0, h = 0, fps = 0, vid = -1, pid = -1;
      if (!get_name(f, c.name) || !get_choice(f, "backend", kCameraBackends, 5, backend, true) ||
          !f.get_string("uri", c.uri, false) || !f.get_int("width", w, false, 1, 8192) ||
          !f.get_int("height", h, false, 1, 8192) || !f.get_int("fps", fps, false, 1, 1000) ||
          !f.get_number("depth_unit_m", c.depth_unit_m, false, true) ||
          !f.get_int("usb_vid", vid, false, 0, 0xffff) || !f.get_int("usb_pid", pid, false, 0, 0xffff))
        return false;
      if ((vid < 0) != (pid < 0)) return f.fail("usb_vid and usb_pid go together");
      const bool any_k = f.has("fx") || f.has("fy") || f.has("cx") || f.has("cy");
      if (any_k && (!f.get_number("fx", c.fx, true, true) || !f.get_number("fy", c.fy, true, true) ||
                    !f.get_number("cx", c.cx, true) || !f.get_number("cy", c.cy, true)))
        return false;
      c.has_intrinsics = any_k;
      c.backend = CameraBackend(backend);
      c.width = int(w);
      c.height = int(h);
      c.fps = int(fps);
      c.has_usb = vid >= 0;
      c.usb_vid = uint16_t(vid < 0 ? 0 : vid);
      c.usb_pid = uint16_t(pid < 0 ? 0 : pid);
      if (c.backend == CameraBackend::kV4l2 && c.uri.empty()) return f.fail("v4l2 needs uri = \"/dev/videoN\"");
      if (c.backend == CameraBackend::kV4l2 && (!c.has_intrinsics || w == 0 || h == 0))
        return f.fail("v4l2 needs width, height, fx, fy, cx, cy (V4L2 reports no intrinsics)");
      for (const BoardCamera& o : out.cameras)
        if (o.name == c.name) return top.fail("camera name '" + c.name + "' is used twice");
      out.cameras.push_back(c);
    }
    for (std::size_t i = 0; scanners && i < scanners->size(); ++i) {
      const toml::table& st = *scanners->get(i)->as_table();
      detail::TomlFields f(st, detail::table_where(path, "line_scanner", i, st), err);
      BoardScanner s;
      int backend = 0;
      if (!get_name(f, s.name) || !get_choice(f, "backend", kScannerBackends, 3, backend, true) ||
          !f.get_string("trigger_pin", s.trigger_pin, false))
        return false;
      s.backend = ScannerBackend(backend);
      if (!s.trigger_pin.empty()) {
        const BoardPin* p = out.find_pin(s.trigger_pin);
        if (!p) return f.fail("trigger_pin '" + s.trigger_pin + "' is not a [[pin]]");
        if (p->direction != PinDirection::kInput) return f.fail("trigger_pin '" + s.trigger_pin + "' is not an input");
      }
      out.scanners.push_back(s);
    }
    hal = out;
    return true;
  });
}

}  // namespace edgefuse::io
