// TUM RGB-D folders (FORMATS.md section 1), alone or as a rig sensor's folder.
#include <cmath>

#include "dataset_internal.hpp"
#include "edgefuse/io/trajectory.hpp"
#include "file_util.hpp"
#include "text_util.hpp"

namespace edgefuse::io::detail {

namespace {

// "timestamp relative/path" lines; stamps strictly increasing, files must exist.
bool read_stamp_list(const std::string& root, const std::string& list_path, std::vector<double>& stamps,
                     std::vector<std::string>& paths, std::string& err) {
  std::string text;
  if (!read_file(list_path, text, err)) return false;
  if (text.empty()) {
    err = list_path + ": empty file, expected 'timestamp path' lines";
    return false;
  }
  stamps.clear();
  paths.clear();
  std::vector<std::string_view> tok;
  LineReader lines(text);
  std::string_view line;
  while (lines.next(line)) {
    if (is_blank_or_comment(line)) continue;
    split_ws(line, tok);
    if (tok.size() != 2) {
      err = format("%s:%d: expected 'timestamp path', got %zu value%s", list_path.c_str(), lines.line_number(),
                   tok.size(), tok.size() == 1 ? "" : "s");
      return false;
    }
    double t = 0;
    if (!parse_double(tok[0], t) || !std::isfinite(t)) {
      err = format("%s:%d: bad timestamp %s", list_path.c_str(), lines.line_number(), quote(tok[0]).c_str());
      return false;
    }
    if (!stamps.empty() && !(t > stamps.back())) {
      err = format("%s:%d: timestamp %.6f is not after the previous %.6f", list_path.c_str(), lines.line_number(), t,
                   stamps.back());
      return false;
    }
    const std::string file = join_path(root, std::string(tok[1]));
    if (!is_regular_file(file)) {
      err = format("%s:%d: listed file %s does not exist", list_path.c_str(), lines.line_number(),
                   printable(file).c_str());
      return false;
    }
    stamps.push_back(t);
    paths.push_back(file);
  }
  if (stamps.empty()) {
    err = list_path + ": lists no frames";
    return false;
  }
  return true;
}

// Attaches to each frame the list's file nearest in time (closer than 0.02 s). Nearest rather than
// associate.py's one-to-one matching: Kinect rgb and depth drift in phase, and one-to-one leaves
// 5 of the 37 TUM frames without colour although each has an image within 15 ms.
bool attach_list(const std::string& root, const char* list_name, std::vector<FrameRef>& frames,
                 std::string FrameRef::*member, std::string& err) {
  std::vector<double> stamps;
  std::vector<std::string> paths;
  if (!read_stamp_list(root, join_path(root, list_name), stamps, paths, err)) return false;
  for (FrameRef& f : frames) {
    const long j = find_nearest_stamp(stamps, f.stamp_s, 0.02);
    if (j >= 0) f.*member = paths[std::size_t(j)];
  }
  return true;
}

}  // namespace

bool open_tum_folder(const std::string& root, const RigSensor* rig_sensor, DepthSequence& seq, std::string& err) {
  DepthSequence out;
  out.root = root;
  out.sensor_name = base_name(root);
  out.layout = SequenceLayout::kTum;
  if (!is_directory(root)) {
    err = root + ": no such folder (sensor folder of the rig)";
    return false;
  }
  // Intrinsics: the rig's, else camera.toml, else ../rig.toml when this is a rig sensor's folder.
  RigToml parent_rig;
  const std::string cam_path = join_path(root, "camera.toml");
  const std::string parent_rig_path = join_path(parent_dir(root), "rig.toml");
  if (!rig_sensor && !is_regular_file(cam_path) && is_regular_file(parent_rig_path)) {
    if (!read_rig_toml(parent_rig_path, parent_rig, err)) return false;
    rig_sensor = parent_rig.find_sensor(out.sensor_name);
    if (!rig_sensor || rig_sensor->kind != SensorKind::kPinhole) {
      err = root + ": no camera.toml, and " + parent_rig_path + " has no pinhole sensor '" + out.sensor_name + "'";
      return false;
    }
  }
  if (rig_sensor) {
    out.layout = SequenceLayout::kRigSensor;
    out.sensor_name = rig_sensor->name;
    out.intr = rig_sensor->pinhole;
  } else {
    CameraToml cam;
    if (!read_camera_toml(cam_path, cam, err)) return false;
    out.intr = cam.intr;
    out.distortion = cam.distortion;
  }

  std::vector<double> stamps;
  std::vector<std::string> paths;
  if (!read_stamp_list(root, join_path(root, "depth.txt"), stamps, paths, err)) return false;
  out.frames.resize(stamps.size());
  for (std::size_t i = 0; i < stamps.size(); ++i) {
    out.frames[i].stamp_s = stamps[i];
    out.frames[i].depth_path = paths[i];
  }

  // A rig says which extra images exist (a missing list is then an error); alone, the lists are used
  // when present.
  const bool want_rgb = rig_sensor ? rig_sensor->color : is_regular_file(join_path(root, "rgb.txt"));
  const bool want_amp = rig_sensor ? rig_sensor->amplitude : is_regular_file(join_path(root, "amplitude.txt"));
  if (want_rgb && !attach_list(root, "rgb.txt", out.frames, &FrameRef::colour_path, err)) return false;
  if (want_amp && !attach_list(root, "amplitude.txt", out.frames, &FrameRef::amplitude_path, err)) return false;
  out.colour_registered = want_rgb;  // TUM (OpenNI) and the rig cameras register colour to depth

  const std::string gt_path = join_path(root, "groundtruth.txt");
  if (is_regular_file(gt_path)) {
    std::vector<StampedPose> gt;
    if (!read_tum_trajectory(gt_path, gt, err)) return false;
    for (FrameRef& f : out.frames)
      if (const StampedPose* p = find_nearest(gt, f.stamp_s, 0.02)) {
        f.has_pose = true;
        f.T_world_cam = p->T;
      }
  }
  seq = std::move(out);
  return true;
}

}  // namespace edgefuse::io::detail
