#include "core_setup.hpp"

#include <algorithm>
#include <cstdio>
#include <cstring>

#include "edgefuse/io/pcd.hpp"
#include "edgefuse/io/ply.hpp"
#include "edgefuse/tsdf/extract.hpp"

namespace edgefuse::cli {

bool CoreSetup::init(const BoardCapacities& board, const PinholeIntrinsics& intr, std::string& err) {
  if (board.volume_dim > build_board().volume_dim || std::strcmp(board.name, build_board().name) != 0) {
    err = "this build's arena is sized for board " + std::string(build_board().name);
    return false;
  }
  if (carve_memory(board, static_arena(), static_arena_bytes(), buffers) != Status::kOk) {
    err = "static arena too small for the memory map";
    return false;
  }
  if (intr.width > board.image_width_max || intr.height > board.image_height_max) {
    err = "a " + std::to_string(intr.width) + "x" + std::to_string(intr.height) + " image exceeds board " + board.name +
          "'s largest image " + std::to_string(board.image_width_max) + "x" + std::to_string(board.image_height_max);
    return false;
  }
  if (intr.validate() != Status::kOk) {
    err = "bad intrinsics";
    return false;
  }
  frame_width = intr.width;
  frame_height = intr.height;
  return true;
}

bool CoreSetup::make_volume(const FuseSettings& s, std::string& err) {
  TsdfParams p = TsdfParams::defaults_for(s.voxel_m, s.trunc_m);
  p.max_weight = uint8_t(s.max_weight);
  const Status st = volume.init(buffers.voxels, s.dim, s.origin_m, p);
  if (st != Status::kOk) {
    err = "volume " + std::to_string(s.dim) + "^3 at " + std::to_string(s.voxel_m) + " m: " + to_string(st);
    return false;
  }
  return true;
}

DepthFrame CoreSetup::stage_frame(const std::vector<uint16_t>& depth, const std::vector<Rgb8>* colour) {
  const int w = frame_width, h = frame_height;
  std::copy(depth.begin(), depth.end(), buffers.depth_frames);
  DepthFrame f;
  f.depth = ImageView<const uint16_t>(buffers.depth_frames, w, h);
  if (colour != nullptr && !colour->empty()) {
    std::copy(colour->begin(), colour->end(), buffers.colour_frames);
    f.colour = ImageView<const Rgb8>(buffers.colour_frames, w, h);
  }
  return f;
}

bool CoreSetup::bind_camera(CameraSlot& cam, int slot, const PinholeIntrinsics& intr, DepthSensorKind kind,
                            bool bilateral, bool colour_map, std::string& err) const {
  const char* why = "";
  if (cam.bind(buffers, build_board(), slot, intr, kind, bilateral, colour_map, &why) == Status::kOk) return true;
  err = why;
  return false;
}

ImageView<uint16_t> CoreSetup::spare_image(int width, int height) const {
  const BoardCapacities& board = build_board();
  return ImageView<uint16_t>(buffers.depth_frames + std::size_t(board.sensors_max - 1) * buffers.pixels_per_sensor,
                             width, height);
}

ViewCentreScratch CoreSetup::centre_scratch(const PinholeIntrinsics& intr) {
  const std::size_t n = std::size_t(intr.width / 2 + 1) * std::size_t(intr.height / 2 + 1);
  centre_xyz.assign(3 * n, 0.0f);
  ViewCentreScratch s;
  s.xs = centre_xyz.data();
  s.ys = s.xs + n;
  s.zs = s.ys + n;
  s.capacity = n;
  return s;
}

std::string CoreSetup::space_usage() const {
  const double brick_bytes = double(kBrickVoxels) * (volume.has_colour() ? 7.0 : 3.0);
  const double mib = 1.0 / (1024.0 * 1024.0);
  char line[256];
  std::snprintf(line, sizeof line, "space: %u of %u bricks in use (%.1f of %.1f MiB of voxels)",
                volume.bricks_in_use(), volume.pool_bricks() - 1u, volume.bricks_in_use() * brick_bytes * mib,
                (volume.pool_bricks() - 1u) * brick_bytes * mib);
  std::string out = line;
  if (volume.bricks_refused() > 0) {
    std::snprintf(line, sizeof line,
                  "; %llu brick stores refused: the pool is full and the map stopped growing (larger voxels, "
                  "or a board with more pool_bricks)",
                  static_cast<unsigned long long>(volume.bricks_refused()));
    out += line;
  }
  return out;
}

int CoreSetup::hit_percent(const RaycastMaps& maps) {
  const int w = maps.depth_m.width, h = maps.depth_m.height;
  std::size_t hits = 0;
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) hits += maps.depth_m.at(u, v) > 0.0f;
  return int(100 * hits / (std::size_t(w) * h));
}

Status CoreSetup::extract_cloud(io::PointCloud& cloud, uint8_t min_weight, bool with_support,
                                int min_point_weight) const {
  const uint32_t capacity = build_board().points_max;
  std::size_t count = 0;
  const Status s = extract_points(volume, buffers.points, capacity, count, min_weight);
  count = keep_supported(volume, buffers.points, count, min_point_weight);
  cloud = io::PointCloud();
  cloud.points.reserve(count);
  cloud.normals.reserve(count);
  bool any_colour = false;
  for (std::size_t i = 0; i < count; ++i) any_colour = any_colour || buffers.points[i].colour.a != 0;
  if (any_colour) cloud.colours.reserve(count);
  if (with_support) cloud.support.reserve(count);
  for (std::size_t i = 0; i < count; ++i) {
    cloud.points.push_back(buffers.points[i].position);
    cloud.normals.push_back(buffers.points[i].normal);
    if (any_colour) cloud.colours.push_back(buffers.points[i].colour);
    if (with_support) cloud.support.push_back(buffers.points[i].support);
  }
  cloud.width = int(count);
  cloud.height = 1;
  return s;
}

bool centre_on_view(const PinholeIntrinsics& intr, const std::vector<uint16_t>& depth, const Pose& T_world_cam,
                    FuseSettings& s, const std::string& depth_path, std::string& err) {
  const std::size_t n = std::size_t(intr.width / 2 + 1) * std::size_t(intr.height / 2 + 1);
  std::vector<float> xyz(3 * n);
  const ViewCentreScratch scratch{xyz.data(), xyz.data() + n, xyz.data() + 2 * n, n};
  Vec3f centre;
  if (view_centre(intr, ImageView<const uint16_t>(depth.data(), intr.width, intr.height), T_world_cam, scratch,
                  centre) == 0) {
    // Usually the camera's numbers, not the image: a wrong depth_scale puts every pixel out of range.
    char what[200];
    std::snprintf(what, sizeof(what), "no pixel's depth (raw / depth_scale %g) lies in [min_range, max_range] = "
                  "[%g, %g] m", double(intr.depth_scale), double(intr.min_range_m), double(intr.max_range_m));
    err = depth_path + ": " + what + ", nothing to centre the volume on (check the camera's depth_scale and "
          "ranges, or give --origin)";
    return false;
  }
  s.origin_m = volume_origin_for(centre, s.dim, s.voxel_m);
  return true;
}

bool write_cloud(const std::string& path, const io::PointCloud& cloud, std::string& err) {
  const bool pcd = path.size() >= 4 && path.compare(path.size() - 4, 4, ".pcd") == 0;
  return pcd ? io::write_pcd(path, cloud, err) : io::write_ply(path, cloud, err);
}

}  // namespace edgefuse::cli
