// Layout detection and frame loading.
#include <exception>
#include <filesystem>
#include <new>

#include "dataset_internal.hpp"
#include "edgefuse/io/png.hpp"
#include "file_util.hpp"

namespace edgefuse::io {

using detail::format;
using detail::join_path;

const char* to_string(SequenceLayout layout) {
  switch (layout) {
    case SequenceLayout::kTum: return "TUM";
    case SequenceLayout::kRigSensor: return "rig sensor";
    case SequenceLayout::kPerFrame: return "per-frame";
    case SequenceLayout::kSingleFrame: return "single frame";
  }
  return "unknown";
}

std::string detail::base_name(const std::string& path) {
  std::string p = path;
  while (p.size() > 1 && p.back() == '/') p.pop_back();
  const std::size_t slash = p.rfind('/');
  return slash == std::string::npos ? p : p.substr(slash + 1);
}

namespace {

bool has_per_frame_depth(const std::string& root) {
  std::error_code ec;
  for (std::filesystem::directory_iterator it(root, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string n = it->path().filename().string();
    if (n.size() > 16 && n.compare(0, 6, "frame-") == 0 && n.compare(n.size() - 10, 10, ".depth.png") == 0) return true;
  }
  return false;
}

bool open_rig(const std::string& root, const std::string& sensor, DepthSequence& seq, std::string& err) {
  RigToml rig;
  const std::string rig_path = join_path(root, "rig.toml");
  if (!read_rig_toml(rig_path, rig, err)) return false;
  const RigSensor* s = nullptr;
  if (sensor.empty()) {
    for (const RigSensor& c : rig.sensors)
      if (c.kind == SensorKind::kPinhole) {
        s = &c;
        break;
      }
    if (!s) {
      err = rig_path + ": no pinhole sensor";
      return false;
    }
  } else {
    s = rig.find_sensor(sensor);
    if (!s) {
      std::string names;
      for (const RigSensor& c : rig.sensors) names += (names.empty() ? "" : ", ") + c.name;
      err = rig_path + ": no sensor named '" + sensor + "' (sensors: " + names + ")";
      return false;
    }
    if (s->kind != SensorKind::kPinhole) {
      err = rig_path + ": sensor '" + sensor + "' is a line_scanner, not a depth camera (see open_line_scan)";
      return false;
    }
  }
  return detail::open_tum_folder(join_path(root, s->name), s, seq, err);
}

bool check_size(const std::string& path, int w, int h, const PinholeIntrinsics& intr, std::string& err) {
  if (w == intr.width && h == intr.height) return true;
  err = format("%s: image is %dx%d but the intrinsics say %dx%d", path.c_str(), w, h, intr.width, intr.height);
  return false;
}

}  // namespace

bool open_depth_sequence(const std::string& path, const std::string& sensor, DepthSequence& seq, std::string& err) {
  return detail::guarded(path, err, [&] {
    if (!detail::is_directory(path)) {
      err = path + (std::filesystem::exists(path) ? ": not a folder, expected a depth sequence folder"
                                                  : ": no such folder");
      return false;
    }
    DepthSequence out;
    bool ok;
    const bool is_rig = detail::is_regular_file(join_path(path, "rig.toml"));
    if (!is_rig && !sensor.empty()) {
      err = path + ": sensor '" + sensor + "' requested but the folder has no rig.toml";
      return false;
    }
    if (is_rig) {
      ok = open_rig(path, sensor, out, err);
    } else if (detail::is_regular_file(join_path(path, "depth.txt"))) {
      ok = detail::open_tum_folder(path, nullptr, out, err);
    } else if (has_per_frame_depth(path)) {
      ok = detail::open_per_frame_folder(path, out, err);
    } else if (detail::is_regular_file(join_path(path, "depth.png"))) {
      ok = detail::open_single_frame_folder(path, out, err);
    } else {
      err = path + ": not a depth sequence (no rig.toml, depth.txt, frame-NNNNNN.depth.png or depth.png)";
      return false;
    }
    if (ok) seq = std::move(out);
    return ok;
  });
}

bool load_depth(const FrameRef& frame, const PinholeIntrinsics& intr, std::vector<uint16_t>& depth, std::string& err) {
  int w = 0, h = 0;
  return read_png_u16(frame.depth_path, depth, w, h, err) && check_size(frame.depth_path, w, h, intr, err);
}

bool load_colour(const FrameRef& frame, const PinholeIntrinsics& intr, std::vector<Rgb8>& colour, std::string& err) {
  if (frame.colour_path.empty()) {
    err = frame.depth_path + ": this frame has no registered colour image";
    return false;
  }
  int w = 0, h = 0;
  return read_png_rgb8(frame.colour_path, colour, w, h, err) && check_size(frame.colour_path, w, h, intr, err);
}

bool load_amplitude(const FrameRef& frame, const PinholeIntrinsics& intr, std::vector<uint16_t>& amplitude,
                    std::string& err) {
  if (frame.amplitude_path.empty()) {
    err = frame.depth_path + ": this frame has no amplitude image";
    return false;
  }
  int w = 0, h = 0;
  return read_png_u16(frame.amplitude_path, amplitude, w, h, err) &&
         check_size(frame.amplitude_path, w, h, intr, err);
}

}  // namespace edgefuse::io
