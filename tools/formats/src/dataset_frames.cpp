// Per-frame folders (7-Scenes, FORMATS.md section 2) and single-frame folders (depth.png).
#include <algorithm>
#include <cmath>
#include <filesystem>

#include "dataset_internal.hpp"
#include "edgefuse/io/png.hpp"
#include "edgefuse/io/trajectory.hpp"
#include "file_util.hpp"

namespace edgefuse::io::detail {

namespace {

// "frame-<digits>.depth.png" -> the number; false for other names.
bool frame_number(const std::string& name, long& n) {
  static const std::string pre = "frame-", suf = ".depth.png";
  if (name.size() <= pre.size() + suf.size() || name.compare(0, pre.size(), pre) != 0 ||
      name.compare(name.size() - suf.size(), suf.size(), suf) != 0)
    return false;
  const std::string digits = name.substr(pre.size(), name.size() - pre.size() - suf.size());
  if (digits.size() > 9) return false;
  n = 0;
  for (char c : digits) {
    if (c < '0' || c > '9') return false;
    n = n * 10 + (c - '0');
  }
  return true;
}

bool close(float a, float b) { return std::fabs(a - b) <= 1e-3f * std::max(1.0f, std::fabs(a)); }

// camera.toml, cross-checked with camera-intrinsics.txt when both exist; or the txt alone, with
// the image size from the first depth PNG and the layout's millimetre depth scale.
bool per_frame_intrinsics(const std::string& root, const std::string& first_depth, DepthSequence& out,
                          std::string& err) {
  const std::string toml_path = join_path(root, "camera.toml");
  const std::string txt_path = join_path(root, "camera-intrinsics.txt");
  const bool has_toml = is_regular_file(toml_path), has_txt = is_regular_file(txt_path);
  float fx = 0, fy = 0, cx = 0, cy = 0;
  if (has_txt && !read_intrinsics_matrix_txt(txt_path, fx, fy, cx, cy, err)) return false;
  if (has_toml) {
    CameraToml cam;
    if (!read_camera_toml(toml_path, cam, err)) return false;
    out.intr = cam.intr;
    out.distortion = cam.distortion;
    if (has_txt && !(close(fx, cam.intr.fx) && close(fy, cam.intr.fy) && close(cx, cam.intr.cx) && close(cy, cam.intr.cy))) {
      err = format("%s: fx fy cx cy = %g %g %g %g disagree with %s (%g %g %g %g)", txt_path.c_str(), fx, fy, cx, cy,
                   toml_path.c_str(), cam.intr.fx, cam.intr.fy, cam.intr.cx, cam.intr.cy);
      return false;
    }
    return true;
  }
  if (!has_txt) {
    err = root + ": no camera.toml or camera-intrinsics.txt";
    return false;
  }
  int w = 0, h = 0, depth = 0, type = 0;
  if (!read_png_info(first_depth, w, h, depth, type, err)) return false;
  out.intr.width = w;
  out.intr.height = h;
  out.intr.fx = fx;
  out.intr.fy = fy;
  out.intr.cx = cx;
  out.intr.cy = cy;
  out.intr.depth_scale = 1000.0f;  // FORMATS.md section 2: millimetres
  return true;
}

}  // namespace

bool open_per_frame_folder(const std::string& root, DepthSequence& seq, std::string& err) {
  DepthSequence out;
  out.root = root;
  out.sensor_name = base_name(root);
  out.layout = SequenceLayout::kPerFrame;
  out.colour_registered = false;  // 7-Scenes colour is not registered to depth: not listed

  std::vector<std::pair<long, std::string>> found;
  std::error_code ec;
  for (std::filesystem::directory_iterator it(root, ec), end; !ec && it != end; it.increment(ec)) {
    long n = 0;
    const std::string name = it->path().filename().string();
    if (frame_number(name, n)) found.emplace_back(n, name);
  }
  if (ec) {
    err = root + ": cannot list the folder (" + ec.message() + ")";
    return false;
  }
  std::sort(found.begin(), found.end());
  for (std::size_t i = 1; i < found.size(); ++i)
    if (found[i].first == found[i - 1].first) {
      err = root + ": " + found[i - 1].second + " and " + found[i].second + " have the same frame number";
      return false;
    }
  if (found.empty()) {
    err = root + ": no frame-NNNNNN.depth.png files";
    return false;
  }
  if (!per_frame_intrinsics(root, join_path(root, found[0].second), out, err)) return false;

  for (const auto& [n, name] : found) {
    FrameRef f;
    f.stamp_s = double(n);  // the layout's convention: timestamp = frame number
    f.depth_path = join_path(root, name);
    const std::string pose_path = join_path(root, name.substr(0, name.size() - 10) + ".pose.txt");
    if (is_regular_file(pose_path)) {
      if (!read_pose_matrix_txt(pose_path, f.T_world_cam, err)) return false;
      f.has_pose = true;
    }
    out.frames.push_back(f);
  }
  seq = std::move(out);
  return true;
}

bool open_single_frame_folder(const std::string& root, DepthSequence& seq, std::string& err) {
  DepthSequence out;
  out.root = root;
  out.sensor_name = base_name(root);
  out.layout = SequenceLayout::kSingleFrame;
  CameraToml cam;
  if (!read_camera_toml(join_path(root, "camera.toml"), cam, err)) return false;
  out.intr = cam.intr;
  out.distortion = cam.distortion;
  FrameRef f;
  f.depth_path = join_path(root, "depth.png");
  const std::string rgb = join_path(root, "rgb.png");
  if (is_regular_file(rgb)) {
    f.colour_path = rgb;
    out.colour_registered = true;  // BOP/LINEMOD depth is registered to the colour camera
  }
  out.frames.push_back(f);
  seq = std::move(out);
  return true;
}

}  // namespace edgefuse::io::detail
