// edgefuse calibrate: finds the mounting T_A_B of two rigidly mounted sensors from the data (paper
// Fig. 6): the space is filled by A at its poses, B's frames taken at the same instants are
// registered to the space raycast at B's guessed mounting (calibrate_pair), the accepted results
// are averaged. Refuses (exit 3) when the scene does not constrain all six directions or the
// registration does not fit, with the reason.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <algorithm>
#include <string>

#include "failure.hpp"
#include "args.hpp"
#include "edgefuse/hal/platform/config/board_defaults.hpp"
#include "calib_store_io.hpp"
#include "commands.hpp"
#include "core_setup.hpp"
#include "edgefuse/fusion/align_spaces.hpp"
#include "rig_calibration.hpp"
#include "rig_fusion.hpp"

namespace edgefuse::cli {
namespace {

const char* kUsage =
    "usage: edgefuse calibrate RIGSET --from A --to B [--frames N] [--guess tx,ty,tz,rx,ry,rz] [--out FILE] [--store DIR]\n"
    "                          [--poses tracked|truth] [--mode pair|maps] [--voxel M] [--trunc M] [--volume N]\n"
    "  Fills the space with sensor A (its first N frames, default all of them; tracked by ICP from its first\n"
    "  ground-truth pose, or with --poses truth at every ground-truth pose), registers B's\n"
    "  frames of the same instants to it and prints T_A_B (pose of B in A's frame) with its\n"
    "  uncertainty. --guess: the mounting to start from (metres, degrees as a rotation vector;\n"
    "  default 0). --out appends 'A B tx ty tz qx qy qz qw' (extrinsics.txt format) to FILE.\n"
    "  --store DIR sets the pair (A, B) in the calibration store in DIR (edgefused's calib.dir: two\n"
    "  CRC-checked slot files, atomic save; the store's other entries are kept).\n"
    "  Exit 3 when the data does not determine the mounting (the reason is printed).\n"
    "  --mode maps: each sensor maps alone into its own space (its first N frames, poses relative to\n"
    "  its first one), and the two spaces' surfaces are aligned (align_spaces); the transform between\n"
    "  the maps is the mounting. Two spaces share the board's voxel storage: default volume 200^3\n"
    "  (256^3 board) of 0.512 m / 200.\n";



// What the command line asks for.
struct CalibrateOptions {
  Args args;
  std::string folder;
  FuseSettings settings;
  int frames = 0;  // 0: every frame of A (set once the sequence is open)
  Pose guess;
  std::string poses;  // tracked | truth
  int default_dim = 0;  // the board's default space (its [tsdf] dim)
};

bool parse_options(int argc, char** argv, CalibrateOptions& o, Failure& f) {
  Args& args = o.args;
  std::string err;
  f.usage = true;
  if (!args.parse(argc, argv, {"from", "to", "frames", "guess", "out", "store", "voxel", "trunc", "volume", "poses", "mode"}, {}, err) ||
      args.positional().size() != 1)
    return fail(f, err.empty() ? "expected one RIGSET" : err, 2);
  if (!args.has("from") || !args.has("to")) return fail(f, "--from and --to are required", 2);
  f.usage = false;
  const BoardCapacities& board = build_board();
  hal::BoardDefaults defaults;
  if (!hal::read_board_defaults(board.name, defaults, err)) return fail(f, err);
  FuseSettings& settings = o.settings;
  settings.voxel_m = defaults.voxel_m;
  settings.trunc_m = defaults.trunc_m;
  settings.max_weight = defaults.max_weight;
  settings.dim = o.default_dim = defaults.dim;
  if (!args.get_float("voxel", 1e-4f, 1.0f, settings.voxel_m, err) ||
      !args.get_float("trunc", 1e-4f, 10.0f, settings.trunc_m, err) ||
      !args.get_int("volume", 8, board.volume_dim, settings.dim, err) || !args.get_int("frames", 1, 100000, o.frames, err) ||
      (args.has("guess") && !parse_guess(args.get("guess"), o.guess, err)))
    return fail(f, err, 2);
  if (!args.has("trunc") && args.has("voxel")) settings.trunc_m = 4.0f * settings.voxel_m;
  if (settings.dim % kBrickSide != 0) return fail(f, "--volume must be a multiple of 8", 2);
  o.poses = args.get("poses", "tracked");
  if (o.poses != "tracked" && o.poses != "truth") return fail(f, "--poses must be tracked or truth, got '" + o.poses + "'", 2);
  if (args.get("from") == args.get("to")) return fail(f, "--from and --to name the same sensor", 2);
  o.folder = args.positional()[0];
  return true;
}

// The rig set and its two pinhole sensors A (--from) and B (--to).
struct SensorPair {
  io::RigSet set;
  RigCamera a, b;
};

bool open_pair(CalibrateOptions& o, SensorPair& p, Failure& f) {
  const Args& args = o.args;
  std::string err;
  if (!io::open_rig_set(o.folder, p.set, err)) return fail(f, err);
  for (const char* opt : {"from", "to"}) {
    const io::RigSensor* s = p.set.rig.find_sensor(args.get(opt));
    if (s == nullptr) return fail(f, o.folder + "/rig.toml has no sensor '" + args.get(opt) + "' (--" + opt + ")", 2);
    if (s->kind != io::SensorKind::kPinhole)
      return fail(f, "--" + std::string(opt) + " " + args.get(opt) + ": only pinhole sensors can be calibrated as a pair", 2);
  }
  p.a.slot = 0;
  p.b.slot = 1;
  if (!io::open_depth_sequence(o.folder, args.get("from"), p.a.seq, err) ||
      !io::open_depth_sequence(o.folder, args.get("to"), p.b.seq, err))
    return fail(f, err);
  if (p.a.seq.frames.empty() || p.b.seq.frames.empty()) return fail(f, "a sensor has no frames");
  // All the data by default: the mounting's scatter falls with the frames averaged (bin_rig_a:
  // 1.26 mm / 0.17 deg from 10 frames, 0.33 mm / 0.06 deg from all 20).
  if (o.frames == 0) o.frames = int(p.a.seq.frames.size());
  const BoardCapacities& board = build_board();
  if (board.sensors_max < 3) return fail(f, "board " + std::string(board.name) + " has fewer than 3 sensor slots");
  return true;
}

void report(const io::RigSet& set, const std::string& folder, const std::string& a, const std::string& b, const Pose& T) {
  for (const io::SensorExtrinsic& e : set.extrinsics)
    if (e.sensor_a == a && e.sensor_b == b) {
      const Pose D = e.T_a_b.inverse() * T;
      std::printf("against %s/extrinsics.txt: %.3f mm, %.4f deg\n", folder.c_str(), 1e3f * (T.t - e.T_a_b.t).norm(),
                  180.0f / 3.14159265f * D.angle_rad());
    }
}

bool append_line(const std::string& path, const std::string& a, const std::string& b, const Pose& T) {
  std::ofstream out(path, std::ios::app);
  out << a << " " << b << " " << pose_line(T) << "\n";
  return bool(out);
}

// --store: the on-board calibration store (both modes).
bool store_result(const Args& args, const std::string& a, const std::string& b, const Pose& T, Failure& f) {
  if (!args.has("store")) return true;
  std::string msg, err;
  if (!store_calibrated_pair(args.get("store"), a, b, T, msg, err)) return fail(f, err);
  std::printf("%s\n", msg.c_str());
  return true;
}

// Two spaces share the board's voxel storage (each half the pool and its own part of the index):
// the largest cube (a multiple of 8) of which two hold the voxels of the board's default space,
// unless --volume; the voxel scaled to keep the default space's extent, unless --voxel.
bool maps_volume_settings(const Args& args, int default_dim, FuseSettings& settings, Failure& f) {
  const BoardCapacities& board = build_board();
  const uint64_t cap3 = uint64_t(board.volume_dim) * board.volume_dim * board.volume_dim;
  const uint64_t base3 = uint64_t(default_dim) * default_dim * default_dim;
  int dim = default_dim;
  while (dim > 8 && 2 * uint64_t(dim) * dim * dim > base3) dim -= 8;
  if (args.has("volume")) dim = settings.dim;
  if (2 * uint64_t(dim) * dim * dim > cap3)
    return fail(f, "--volume " + std::to_string(dim) + ": two such spaces do not fit the board's brick index", 2);
  if (!args.has("voxel")) settings.voxel_m = settings.voxel_m * float(default_dim) / float(dim);
  if (!args.has("trunc")) settings.trunc_m = 4.0f * settings.voxel_m;
  settings.dim = dim;
  return true;
}

// The board's voxel storage as two spaces of dim^3 voxels (distance and weight, no colour), each
// with half the voxel pool.
void split_voxel_storage(const VoxelStorage& all, int dim, VoxelStorage (&out)[2]) {
  const std::size_t bricks = std::size_t(dim) * dim * dim / kBrickVoxels;
  const uint32_t pool = all.pool_bricks / 2u;
  const std::size_t pool_voxels = std::size_t(pool) * kBrickVoxels;
  out[0] = out[1] = all;
  for (VoxelStorage& s : out) {
    s.colour = nullptr;
    s.colour_weight = nullptr;
    s.capacity_dim = dim;
    s.pool_bricks = pool;
  }
  out[1].tsdf += pool_voxels;
  out[1].weight += pool_voxels;
  out[1].brick_slot += bricks;
  out[1].brick_flags += bricks;
  out[1].brick_list += bricks;
  if (out[1].block_mask != nullptr) out[1].block_mask += bricks;
}

// One sensor maps alone into its own space (centred on its first view), through the pipeline's
// Mapper at its recorded poses relative to its first one.
bool map_alone(RigCamera& c, FuseSettings settings, const VoxelStorage& storage, TsdfVolume& space,
               ImageView<uint16_t> spare, CoreSetup& core, int frames, Failure& f) {
  std::string err;
  if (!c.seq.frames[0].has_pose) return fail(f, c.seq.root + ": frames need poses (groundtruth.txt)");
  const Pose T0_inv = c.seq.frames[0].T_world_cam.inverse();
  if (!io::load_depth(c.seq.frames[0], c.seq.intr, c.load_depth, err)) return fail(f, err);
  if (!centre_on_view(c.seq.intr, c.load_depth, Pose::identity(), settings, c.seq.frames[0].depth_path, err))
    return fail(f, err);
  const TsdfParams tp = TsdfParams::defaults_for(settings.voxel_m, settings.trunc_m);
  if (space.init(storage, settings.dim, settings.origin_m, tp) != Status::kOk) return fail(f, "space init failed");
  Mapper mapper;
  if (mapper.init(space, KernelRunners(), spare, core.centre_scratch(c.seq.intr), MapperParams()) != Status::kOk)
    return fail(f, "mapping refused");
  mapper.new_map_in_place();
  const std::size_t n = std::min<std::size_t>(std::size_t(frames), c.seq.frames.size());
  for (std::size_t i = 0; i < n; ++i) {
    if (!c.seq.frames[i].has_pose) continue;
    SensorFrame frame;
    if (!c.load(i, false, frame, err)) return fail(f, err);
    const Status s = mapper.map_at(c.cam, frame, T0_inv * c.seq.frames[i].T_world_cam);
    if (s != Status::kOk) return fail(f, c.seq.frames[i].depth_path + ": " + to_string(s));
  }
  return true;
}

// --mode maps: two spaces carved from the board's one voxel storage, each filled by one sensor in
// its own frame (its first pose), then aligned.
bool calibrate_maps(const CalibrateOptions& o, SensorPair& p, Failure& f) {
  const Args& args = o.args;
  const BoardCapacities& board = build_board();
  FuseSettings settings = o.settings;
  RigCamera& a = p.a;
  RigCamera& b = p.b;
  std::string err;
  if (!maps_volume_settings(args, o.default_dim, settings, f)) return false;
  CoreSetup core;
  if (!core.init(board, a.seq.intr, err)) return fail(f, err);
  if (!a.bind(core, true, err) || !b.bind(core, true, err)) return fail(f, err);
  a.cam.filters.bilateral_enabled = false;
  b.cam.filters.bilateral_enabled = false;
  const ImageView<uint16_t> spare(core.buffers.depth_frames + 2 * core.buffers.pixels_per_sensor,
                                  board.image_width_max, board.image_height_max);
  TsdfVolume space[2];
  VoxelStorage space_storage[2];
  split_voxel_storage(core.buffers.voxels, settings.dim, space_storage);
  RigCamera* cam[2] = {&a, &b};
  for (int k = 0; k < 2; ++k)
    if (!map_alone(*cam[k], settings, space_storage[k], space[k], spare, core, o.frames, f)) return false;
  std::printf("edgefuse calibrate --mode maps: A = %s, B = %s, each mapped alone (%d frames, poses relative to its "
              "first), two %d^3 spaces of %.4f m\n",
              a.seq.sensor_name.c_str(), b.seq.sensor_name.c_str(), o.frames, settings.dim, settings.voxel_m);
  // View: A's first pose in A's map, with A's intrinsics; the other space's maps use slot 1's buffers.
  const PinholeIntrinsics& vi = a.seq.intr;
  const RaycastMaps om = core.buffers.raycast_maps(1, vi.width, vi.height, false);
  FramePyramid<real_t> pyramid;
  if (core.buffers.pyramid<real_t>(1, vi, pyramid) != Status::kOk) return fail(f, "pyramid does not fit");
  PairCalibrationResult r;
  if (align_spaces<real_t>(space[0], space[1], vi, Pose::identity(), o.guess, pyramid, a.cam.maps, om,
                           ImageView<uint16_t>(spare.data, vi.width, vi.height), core.buffers.icp_workspace<real_t>(1),
                           PairCalibrationParams(), 3, r) != Status::kOk)
    return fail(f, "alignment failed");
  if (!r.accepted) return fail(f, std::string("refused: ") + r.reason, 3);
  const float deg = 180.0f / 3.14159265f;
  std::printf("T_%s_%s = %s   (map of %s in map of %s; rms %.2f mm, inliers %.2f, %d correspondences)\n",
              a.seq.sensor_name.c_str(), b.seq.sensor_name.c_str(), pose_line(r.T_a_b).c_str(),
              b.seq.sensor_name.c_str(), a.seq.sensor_name.c_str(), 1e3f * r.rms_m, r.inlier_ratio, r.correspondences);
  std::printf("uncertainty (1 sigma): covariance rot %.4f %.4f %.4f deg, trans %.3f %.3f %.3f mm\n", deg * r.sigma(0),
              deg * r.sigma(1), deg * r.sigma(2), 1e3f * r.sigma(3), 1e3f * r.sigma(4), 1e3f * r.sigma(5));
  report(p.set, args.positional()[0], a.seq.sensor_name, b.seq.sensor_name, r.T_a_b);
  if (args.has("out") && !append_line(args.get("out"), a.seq.sensor_name, b.seq.sensor_name, r.T_a_b))
    return fail(f, "cannot write " + args.get("out"));
  return store_result(args, a.seq.sensor_name, b.seq.sensor_name, r.T_a_b, f);
}

// --mode pair: the core's buffers (A in slot 0, B in slot 1, the filters' scratch in slot 2), the
// space centred on what A's first frame sees.
struct PairCore {
  CoreSetup core;
  ImageView<uint16_t> filter_scratch;
};

bool set_up_core(CalibrateOptions& o, SensorPair& p, PairCore& pc, Failure& f) {
  const BoardCapacities& board = build_board();
  RigCamera& a = p.a;
  CoreSetup& core = pc.core;
  std::string err;
  if (!core.init(board, a.seq.intr, err)) return fail(f, err);
  if (!a.bind(core, true, err) || !p.b.bind(core, true, err)) return fail(f, err);
  pc.filter_scratch = ImageView<uint16_t>(core.buffers.depth_frames + 2 * core.buffers.pixels_per_sensor,
                                          board.image_width_max, board.image_height_max);
  if (!io::load_depth(a.seq.frames[0], a.seq.intr, a.load_depth, err)) return fail(f, err);
  if (!a.seq.frames[0].has_pose) return fail(f, a.seq.root + ": A's frames need poses (groundtruth.txt)");
  if (!centre_on_view(a.seq.intr, a.load_depth, a.seq.frames[0].T_world_cam, o.settings, a.seq.frames[0].depth_path,
                      err))
    return fail(f, err);
  if (!core.make_volume(o.settings, err)) return fail(f, err);
  return true;
}

// A fills the space (tracked or at its ground truth), B's frames at the same instants are registered to it.
bool calibrate_pair_frames(const CalibrateOptions& o, SensorPair& p, PairCore& pc, PairCalibrationRun& run,
                           Failure& f) {
  RigCamera& a = p.a;
  RigCamera& b = p.b;
  std::string err;
  std::printf("edgefuse calibrate: %s, A = %s (%dx%d), B = %s (%dx%d), %d frames, voxel %.4f m, guess %s\n",
              o.folder.c_str(), a.seq.sensor_name.c_str(), a.seq.intr.width, a.seq.intr.height,
              b.seq.sensor_name.c_str(), b.seq.intr.width, b.seq.intr.height, o.frames, o.settings.voxel_m,
              pose_line(o.guess).c_str());
  PairCalibrationSetup setup;
  setup.volume = &pc.core.volume;
  setup.filter_scratch = pc.filter_scratch;
  setup.centre = pc.core.centre_scratch(a.seq.intr);
  setup.frames = o.frames;
  setup.guess = o.guess;
  setup.track_a = o.poses == "tracked";
  setup.verbose = true;
  if (!run_pair_calibration(a, b, setup, run, err)) return fail(f, err);
  if (setup.track_a)
    std::printf("A tracked: %d of %d frames ok, largest distance from its ground truth %.2f mm\n", run.a_tracked_ok,
                std::min(o.frames, int(a.seq.frames.size())), run.a_pose_error_mm);
  if (run.accepted == 0)
    return fail(f, "refused: " + (run.first_reason.empty() ? std::string("no frame of B at A's instants") : run.first_reason),
                3);
  return true;
}

// The mounting with its uncertainty, against the set's extrinsics.txt when it has the pair; --out, --store.
bool write_result(const CalibrateOptions& o, const SensorPair& p, const PairCalibrationRun& run, Failure& f) {
  const std::string& a = p.a.seq.sensor_name;
  const std::string& b = p.b.seq.sensor_name;
  const Pose& T = run.T_a_b;
  const float deg = 180.0f / 3.14159265f;
  std::printf("T_%s_%s = %s   (tx ty tz qx qy qz qw; %d of %zu frames accepted)\n", a.c_str(), b.c_str(),
              pose_line(T).c_str(), run.accepted, run.frames.size());
  std::printf("uncertainty (1 sigma, B frame): covariance rot %.4f %.4f %.4f deg, trans %.3f %.3f %.3f mm",
              deg * run.sigma(0), deg * run.sigma(1), deg * run.sigma(2), 1e3f * run.sigma(3), 1e3f * run.sigma(4),
              1e3f * run.sigma(5));
  if (run.accepted > 1)
    std::printf("; spread over frames rot %.4f %.4f %.4f deg, trans %.3f %.3f %.3f mm", deg * run.spread(0),
                deg * run.spread(1), deg * run.spread(2), 1e3f * run.spread(3), 1e3f * run.spread(4),
                1e3f * run.spread(5));
  std::printf("\n");
  report(p.set, o.folder, a, b, T);
  if (o.args.has("out")) {
    if (!append_line(o.args.get("out"), a, b, T)) return fail(f, "cannot write " + o.args.get("out"));
    std::printf("written to %s\n", o.args.get("out").c_str());
  }
  return store_result(o.args, a, b, T, f);
}

}  // namespace

int cmd_calibrate(int argc, char** argv) {
  if (help_asked(argc, argv, kUsage)) return 0;
  CalibrateOptions o;
  Failure f;
  SensorPair p;
  if (!parse_options(argc, argv, o, f) || !open_pair(o, p, f)) return report("edgefuse calibrate", f, kUsage);
  const std::string mode = o.args.get("mode", "pair");
  if (mode != "pair" && mode != "maps") return report("edgefuse calibrate", Failure{"--mode must be pair or maps, got '" + mode + "'", 2});
  if (mode == "maps") return calibrate_maps(o, p, f) ? 0 : report("edgefuse calibrate", f, kUsage);
  PairCore pc;
  PairCalibrationRun run;
  if (!set_up_core(o, p, pc, f) || !calibrate_pair_frames(o, p, pc, run, f) || !write_result(o, p, run, f))
    return report("edgefuse calibrate", f, kUsage);
  return 0;
}

}  // namespace edgefuse::cli
