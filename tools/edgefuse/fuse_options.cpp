#include "fuse_options.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "edgefuse/hal/platform/config/board_defaults.hpp"
#include "edgefuse/memory/arena.hpp"
#include "edgefuse/pipeline/view_centre.hpp"

namespace edgefuse::cli {

bool board_fuse_settings(FuseSettings& settings, std::string& err) {
  const BoardCapacities& board = build_board();
  hal::BoardDefaults defaults;
  if (!hal::read_board_defaults(board.name, defaults, err)) return false;
  settings.voxel_m = defaults.voxel_m;
  settings.trunc_m = defaults.trunc_m;
  settings.max_weight = defaults.max_weight;
  settings.threads = defaults.threads;
  settings.dim = defaults.dim;
  return true;
}

bool apply_fuse_options(const Args& args, FuseSettings& settings, int& frames_max, std::string& err) {
  frames_max = 1 << 30;
  if (!args.get_float("voxel", 1e-4f, 1.0f, settings.voxel_m, err) ||
      !args.get_float("trunc", 1e-4f, 10.0f, settings.trunc_m, err) ||
      !args.get_int("volume", 8, build_board().volume_dim, settings.dim, err) ||
      !args.get_int("threads", 1, 64, settings.threads, err) || !args.get_int("frames", 1, 1 << 30, frames_max, err) ||
      !args.get_vec3("origin", settings.origin_m, err))
    return false;
  if (!args.has("trunc") && args.has("voxel")) settings.trunc_m = 4.0f * settings.voxel_m;
  settings.origin_given = args.has("origin");
  settings.voxel_given = args.has("voxel");
  settings.trunc_given = args.has("trunc");
  settings.volume_given = args.has("volume");
  char what[128];
  if (settings.dim % kBrickSide != 0) {
    std::snprintf(what, sizeof what, "--volume must be a multiple of %d, got %d", kBrickSide, settings.dim);
    err = what;
    return false;
  }
  if (settings.trunc_m < settings.voxel_m) {
    std::snprintf(what, sizeof what, "--trunc (%g m) must be at least one voxel (%g m)", double(settings.trunc_m),
                  double(settings.voxel_m));
    err = what;
    return false;
  }
  return true;
}

namespace {

// A view is held when this share of its in-range points lies inside the space: room for the odd
// far wall or window, while the part tracking aligns against stays in.
constexpr float kHeldShare = 0.9f;
// A space the user chose is warned about only below this share: one that holds most of the view
// (TUM fr1/xyz at --voxel 0.01 holds 86 %) is a choice, one that holds a sixth of it is a mistake.
constexpr float kWarnShare = 0.5f;
// Voxel edges the default space grows through (metres). 2 cm is the coarsest a gripper's map is
// still useful at; beyond it the command refuses and names the voxel that would do.
constexpr float kVoxelLadder_m[] = {0.004f, 0.005f, 0.01f, 0.02f};

// The first frame's in-range points in the world frame (every 2nd pixel of every 2nd row, as
// view_centre() samples) and the nearest and farthest depth among them.
struct ViewPoints {
  std::vector<Vec3f> world_m;
  float near_m = 0.0f, far_m = 0.0f;
};

//! Collects the view's points. \param intr the sensor  \param depth raw z-depth
//! \param T_world_cam its pose  \param view filled in
void collect_view(const PinholeIntrinsics& intr, const std::vector<uint16_t>& depth, const Pose& T_world_cam,
                  ViewPoints& view) {
  view.near_m = intr.max_range_m;
  view.far_m = intr.min_range_m;
  for (int v = 0; v < intr.height; v += 2)
    for (int u = 0; u < intr.width; u += 2) {
      const uint16_t raw = depth[std::size_t(v) * std::size_t(intr.width) + std::size_t(u)];
      const float z_m = float(raw) / intr.depth_scale;
      if (raw == 0 || z_m < intr.min_range_m || z_m > intr.max_range_m) continue;
      view.world_m.push_back(T_world_cam * intr.back_project(float(u), float(v), z_m));
      view.near_m = std::min(view.near_m, z_m);
      view.far_m = std::max(view.far_m, z_m);
    }
}

//! Share of the points inside the cube. \param points_m world points  \param origin_m the cube's corner
//! \param dim voxels per axis  \param voxel_m voxel edge
float share_inside(const std::vector<Vec3f>& points_m, const Vec3f& origin_m, int dim, float voxel_m) {
  const Vec3f far_m = origin_m + Vec3f::Constant(float(dim) * voxel_m);
  std::size_t in = 0;
  for (const Vec3f& p : points_m)
    in += (p.array() >= origin_m.array()).all() && (p.array() < far_m.array()).all();
  return points_m.empty() ? 1.0f : float(in) / float(points_m.size());
}

//! Where a dim^3 space of voxel_m voxels would stand: at --origin, else centred on the view.
//! \param s the settings (origin_given, origin_m)  \param centre_m the view's median point
//! \param voxel_m the voxel edge tried
Vec3f origin_for(const FuseSettings& s, const Vec3f& centre_m, float voxel_m) {
  return s.origin_given ? s.origin_m : volume_origin_for(centre_m, s.dim, voxel_m);
}

//! The smallest voxel (ladder, then doubling up to --voxel's 1 m limit) whose space holds the view;
//! 0 when none does. \param view the points  \param s the settings  \param centre_m the view's median
//! \param from_m only voxels above this are tried
float voxel_holding(const ViewPoints& view, const FuseSettings& s, const Vec3f& centre_m, float from_m) {
  for (float v_m : kVoxelLadder_m)
    if (v_m > from_m && share_inside(view.world_m, origin_for(s, centre_m, v_m), s.dim, v_m) >= kHeldShare)
      return v_m;
  for (float v_m = 0.04f; v_m <= 1.0f; v_m *= 2.0f)
    if (v_m > from_m && share_inside(view.world_m, origin_for(s, centre_m, v_m), s.dim, v_m) >= kHeldShare)
      return v_m;
  return 0.0f;
}

//! "2 mm", "1 cm", "4 cm": a length as a person would say it. \param length_m the length
std::string length_text(float length_m) {
  char text[32];
  if (length_m < 0.01f - 1e-6f)
    std::snprintf(text, sizeof text, "%g mm", double(std::round(length_m * 1e4f) / 10.0f));
  else
    std::snprintf(text, sizeof text, "%g cm", double(std::round(length_m * 1e3f) / 10.0f));
  return text;
}

//! "the first frame spans 0.6-3.9 m; the board's 256^3 x 2 mm space (0.51 m) holds 12 % of it".
//! \param view the points  \param s the settings as they stand  \param share the share held
//! \param board_defaults whether the space is the board's default
std::string shortfall_text(const ViewPoints& view, const FuseSettings& s, float share, bool board_defaults) {
  char text[200];
  std::snprintf(text, sizeof text, "the first frame spans %.1f-%.1f m; %s %d^3 x %s space (%.2f m) holds %d %% of it",
                double(view.near_m), double(view.far_m), board_defaults ? "the board's" : "the", s.dim,
                length_text(s.voxel_m).c_str(), double(float(s.dim) * s.voxel_m), int(100.0f * share));
  return text;
}

//! The --voxel advice: "pass --voxel 0.01 (2.56 m) to hold 90 %". \param s the settings
//! \param voxel_m the voxel that would hold the view (0: none up to 1 m)
std::string voxel_advice(const FuseSettings& s, float voxel_m) {
  char text[160];
  if (voxel_m <= 0.0f)
    std::snprintf(text, sizeof text, "no voxel up to 1 m holds %d %% (check the pose and the camera's ranges)",
                  int(100.0f * kHeldShare));
  else
    std::snprintf(text, sizeof text, "pass --voxel %g (%.2f m) to hold %d %%", double(voxel_m),
                  double(float(s.dim) * voxel_m), int(100.0f * kHeldShare));
  return text;
}

}  // namespace

bool size_space_to_view(const char* command, const PinholeIntrinsics& intr, const std::vector<uint16_t>& depth,
                        const Pose& T_world_cam, FuseSettings& s, const std::string& depth_path, std::string& err) {
  if (!s.origin_given && !centre_on_view(intr, depth, T_world_cam, s, depth_path, err)) return false;
  ViewPoints view;
  collect_view(intr, depth, T_world_cam, view);
  const Vec3f centre_m = s.origin_m + Vec3f::Constant(0.5f * float(s.dim) * s.voxel_m);  // the median, unless --origin
  const float share = share_inside(view.world_m, s.origin_m, s.dim, s.voxel_m);
  if (share >= kHeldShare) return true;
  const bool board_defaults = !s.voxel_given && !s.volume_given && !s.origin_given;
  const std::string shortfall = shortfall_text(view, s, share, board_defaults);
  if (!board_defaults) {  // the user chose the space: say what it misses, change nothing
    if (share < kWarnShare)
      std::printf("%s: warning: %s; only that part is %s: %s\n", command, shortfall.c_str(),
                  std::strcmp(command, "track") == 0 ? "fused and tracked against" : "fused",
                  voxel_advice(s, voxel_holding(view, s, centre_m, s.voxel_m)).c_str());
    return true;
  }
  // The index holds more than the default space: first the board's voxel over the whole index, then
  // coarser voxels over it (the voxel pool holds the surface, whatever the extent).
  FuseSettings grown = s;
  grown.dim = build_board().volume_dim;
  float chosen_m = 0.0f;
  if (grown.dim > s.dim &&
      share_inside(view.world_m, origin_for(grown, centre_m, s.voxel_m), grown.dim, s.voxel_m) >= kHeldShare)
    chosen_m = s.voxel_m;
  for (float v_m : kVoxelLadder_m)
    if (chosen_m == 0.0f && v_m > s.voxel_m &&
        share_inside(view.world_m, origin_for(grown, centre_m, v_m), grown.dim, v_m) >= kHeldShare)
      chosen_m = v_m;
  if (chosen_m == 0.0f) {
    char keep[64];
    std::snprintf(keep, sizeof keep, ", or --voxel %g to fuse only the part inside", double(s.voxel_m));
    err = shortfall + ", and no voxel up to " + length_text(kVoxelLadder_m[3]) + " holds " +
          std::to_string(int(100.0f * kHeldShare)) + " %: " +
          voxel_advice(s, voxel_holding(view, s, centre_m, kVoxelLadder_m[3])) + keep;
    return false;
  }
  const float trunc_m = s.trunc_given ? s.trunc_m : 4.0f * chosen_m;
  if (trunc_m < chosen_m) {
    err = shortfall + "; a " + length_text(chosen_m) + " voxel would hold it, but --trunc " + length_text(trunc_m) +
          " is below one voxel: pass --voxel and --trunc together";
    return false;
  }
  s.dim = grown.dim;
  s.voxel_m = chosen_m;
  s.trunc_m = trunc_m;
  s.origin_m = volume_origin_for(centre_m, s.dim, s.voxel_m);
  std::printf("%s: %s: using %d^3 x %s voxels (%.2f m), pass --voxel to choose\n", command, shortfall.c_str(), s.dim,
              length_text(chosen_m).c_str(), double(float(s.dim) * chosen_m));
  return true;
}

}  // namespace edgefuse::cli
