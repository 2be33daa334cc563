#include "fuse_options.hpp"

#include <cstdio>

#include "edgefuse/hal/platform/config/board_defaults.hpp"
#include "edgefuse/memory/arena.hpp"

namespace edgefuse::cli {

bool board_fuse_settings(FuseSettings& settings, std::string& err) {
  const BoardCapacities& board = build_board();
  hal::BoardDefaults defaults;
  if (!hal::read_board_defaults(board.name, defaults, err)) return false;
  settings.voxel_m = defaults.voxel_m;
  settings.trunc_m = defaults.trunc_m;
  settings.max_weight = defaults.max_weight;
  settings.threads = defaults.threads;
  settings.dim = board.volume_dim;
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

}  // namespace edgefuse::cli
