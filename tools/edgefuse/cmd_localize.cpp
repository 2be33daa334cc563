// edgefuse localize: object poses (model-based, PPF voting + ICP + verification) or model-free
// segments on a rig set fused at its ground-truth poses, a single depth frame (fused into the
// space, so the free-space check works), or a PLY/PCD cloud.
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <sys/stat.h>
#include <vector>

#include "args.hpp"
#include "board_defaults.hpp"
#include "commands.hpp"
#include "core_setup.hpp"
#include "edgefuse/filters/depth_filter_chain.hpp"
#include "edgefuse/io/dataset.hpp"
#include "edgefuse/tracking/tracker.hpp"
#include "edgefuse/io/pcd.hpp"
#include "edgefuse/io/ply.hpp"
#include "edgefuse/localize/localizer.hpp"
#include "edgefuse/tsdf/extract.hpp"
#include "localize_io.hpp"
#include "edgefuse/hal/platform/threads/parallel_tsdf.hpp"
#include "rig_fusion.hpp"

namespace edgefuse::cli {
namespace {

const char* kUsage =
    "usage: edgefuse localize INPUT --model FILE.ply [--model FILE ...] [--max N] [--out poses.txt]\n"
    "       edgefuse localize INPUT --segments [--max N] [--out labels.pcd]\n"
    "  options: [--sensor NAME | --sensors A,B,...] [--frames N] [--voxel M] [--volume N] [--threads N] [--no-walls] [--min-score S]\n"
    "           [--icp-iterations N] (per hypothesis, default 12)\n"
    "           [--max-incidence DEG] (model surface seen more obliquely is not expected in the scene, default 75)\n"
    "           [--no-rest-poses] (no second round of rest-pose hypotheses: parts on the floor on a stable face,\n"
    "           x, y and yaw voted from heights above the floor, on the surface the first round left unexplained)\n"
    "           [--scene-out FILE.ply] (the scene after bin removal, for inspection)\n"
    "           [--bin FILE.toml] (the bin's floor pose and inner size from configuration instead of detection;\n"
    "           [bin] pose = [tx, ty, tz, qx, qy, qz, qw] (T_world_bin, z up, origin at the inner floor's centre),\n"
    "           inner_size_m = [x, y])\n"
    "           [--config FILE.toml] (models and bin named in a runtime configuration: [localize] models = a PLY,\n"
    "           a folder of them or a list of files, [localize] bin = a --bin file; paths relative to the file)\n"
    "           [--seg-smooth DEG] [--seg-concave TOL] [--seg-radius M] [--seg-colour TOL]\n"
    "           [--seg-crease DEG (0: off)] [--seg-crease-radius M] [--seg-crease-concave C] [--seg-crease-pairs N]\n"
    "           [--seg-crease-share S] [--seg-keep-small] (region growing, its concave-crease cut and the merge of\n"
    "           small pieces into their neighbour, see localizer.hpp)\n"
    "  INPUT: a rig set or depth-sequence folder (fused at its ground-truth poses), a single-frame folder\n"
    "  (depth.png + camera.toml, fused as one frame), or a PLY/PCD cloud (organised clouds get normals from\n"
    "  their image neighbours, unorganised ones without normals by PCA; no free-space check on clouds).\n"
    "  --track: fuse a sequence at poses tracked by ICP against the fused model (as `edgefuse track`: pre-filters,\n"
    "  first pose from the set, push after 1 cm / 1 deg or with [--push-every-frame]) instead of its ground-truth poses.\n"
    "  --sensors A,B,..: fuse these sensors of a rig set (as `edgefuse fuse --sensors`: pre-filters, noise-model\n"
    "  trust, line scanners) into the one space that is localised in; the viewpoint is the first colour camera's;\n"
    "  with [--no-filter] [--no-trust] [--min-weight W] (as for `edgefuse fuse`); [--fusion-rules]: also the noise\n"
    "  rules of `edgefuse fuse --sensors` (depth jump 2.83 sigma, sub-unit fill and support rule by set; off by default: BENCHMARKS\n"
    "  \"Multi-sensor fusion, round 5\"), or [--min-support W] [--jump-sigmas K] given alone.\n"
    "  Poses: one line per object `id tx ty tz qx qy qz qw score model` (T_world_object; id = picking rank).\n"
    "  --check-truth (rig sets): also verifies every true object pose of objects.txt (at the truth and after ICP\n"
    "  from it) as a hypothesis would be, to show why a known object is missed.\n"
    "  Segments: a PCD with a `label` field per input point (organised inputs keep width x height; 0 = none).\n";

double cpu_ms(clockid_t clock = CLOCK_THREAD_CPUTIME_ID) {
  timespec ts;
  clock_gettime(clock, &ts);
  return double(ts.tv_sec) * 1e3 + double(ts.tv_nsec) * 1e-6;
}

bool is_dir(const std::string& p) {
  struct stat st;
  return stat(p.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}


bool ends_with(const std::string& s, const char* e) {
  const std::size_t n = std::strlen(e);
  return s.size() >= n && s.compare(s.size() - n, n, e) == 0;
}

}  // namespace

int cmd_localize(int argc, char** argv) {
  // --model may repeat: collect those pairs first, hand the rest to Args.
  std::vector<std::string> model_files;
  std::vector<char*> rest;
  for (int i = 0; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--model")) {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "edgefuse localize: option --model needs a value\n%s", kUsage);
        return 2;
      }
      model_files.push_back(argv[++i]);
    } else {
      rest.push_back(argv[i]);
    }
  }
  Args args;
  std::string err;
  if (!args.parse(int(rest.size()), rest.data(), {"max", "out", "sensor", "sensors", "frames", "voxel", "volume", "threads", "min-score", "scene-out", "min-weight", "icp-iterations", "max-incidence", "bin", "config", "seg-smooth", "seg-concave", "seg-radius", "seg-colour", "seg-crease", "seg-crease-radius", "seg-crease-concave", "seg-crease-pairs", "seg-crease-share", "min-support", "jump-sigmas"},
                  {"segments", "seg-keep-small", "no-walls", "no-filter", "no-trust", "check-truth", "track", "push-every-frame", "no-rest-poses",
                   "fusion-rules"}, err) ||
      args.positional().size() != 1) {
    std::fprintf(stderr, "edgefuse localize: %s\n%s", err.empty() ? "expected one INPUT" : err.c_str(), kUsage);
    return 2;
  }
  const bool segments = args.has("segments");
  std::string config_bin;
  if (args.has("config")) {  // models (and the bin) named in a runtime configuration, as edgefused reads them
    std::vector<std::string> config_models;
    if (!read_localize_config(args.get("config"), config_models, config_bin, err)) {
      std::fprintf(stderr, "edgefuse localize: --config: %s\n", err.c_str());
      return 2;
    }
    if (!segments) model_files.insert(model_files.end(), config_models.begin(), config_models.end());
  }
  if (!segments && model_files.empty()) {
    std::fprintf(stderr, "edgefuse localize: give at least one --model FILE (or --segments)\n%s", kUsage);
    return 2;
  }
  const BoardCapacities& board = build_board();
  BoardDefaults defaults;
  if (!read_board_defaults(board.name, defaults, err)) {
    std::fprintf(stderr, "edgefuse localize: %s\n", err.c_str());
    return 1;
  }
  int max_results = board.objects_max, frames_max = 1 << 30;
  FuseSettings fs;
  fs.voxel_m = defaults.voxel_m;
  fs.trunc_m = defaults.trunc_m;
  fs.max_weight = defaults.max_weight;
  fs.threads = defaults.threads;
  fs.dim = board.volume_dim;
  LocalizeParams params;
  if (args.has("seg-keep-small")) params.segment_merge_small = false;
  if (!args.get_int("max", 1, board.objects_max, max_results, err) || !args.get_int("frames", 1, 1 << 30, frames_max, err) ||
      !args.get_float("voxel", 1e-4f, 1.0f, fs.voxel_m, err) || !args.get_int("volume", 8, board.volume_dim, fs.dim, err) ||
      !args.get_int("threads", 1, 64, fs.threads, err) || !args.get_float("min-score", 0.0f, 1.0f, params.min_score, err) ||
      !args.get_float("seg-smooth", 0.0f, 90.0f, params.segment_smooth_deg, err) ||
      !args.get_float("seg-concave", -1.0f, 1.0f, params.segment_concave_tol, err) ||
      !args.get_float("seg-radius", 0.001f, 0.1f, params.segment_radius_m, err) ||
      !args.get_int("seg-colour", 0, 765, params.segment_colour_tol, err) ||
      !args.get_float("seg-crease", 0.0f, 90.0f, params.segment_crease_deg, err) ||
      !args.get_float("seg-crease-radius", 0.001f, 0.1f, params.segment_crease_radius_m, err) ||
      !args.get_float("seg-crease-concave", 0.0f, 1.5f, params.segment_crease_concave, err) ||
      !args.get_int("seg-crease-pairs", 1, 10000, params.segment_crease_min_pairs, err) ||
      !args.get_float("seg-crease-share", 0.0f, 1.0f, params.segment_crease_share, err) ||
      !args.get_int("icp-iterations", 1, 100, params.icp_iterations, err) ||
      !args.get_float("max-incidence", 1.0f, 90.0f, params.max_incidence_deg, err)) {
    std::fprintf(stderr, "edgefuse localize: %s\n", err.c_str());
    return 2;
  }
  if (args.has("voxel")) fs.trunc_m = 4.0f * fs.voxel_m;
  if (fs.dim % kBrickSide != 0) {
    std::fprintf(stderr, "edgefuse localize: --volume must be a multiple of %d\n", kBrickSide);
    return 2;
  }
  params.detect_walls = !args.has("no-walls");
  params.rest_poses = !args.has("no-rest-poses");
  params.max_per_model = max_results;

  BinGeometry bin_config;
  const std::string bin_file = args.has("bin") ? args.get("bin") : config_bin;  // the command line wins
  const bool bin_from_config = !bin_file.empty();
  if (bin_from_config && !read_bin_toml(bin_file, bin_config, err)) {
    std::fprintf(stderr, "edgefuse localize: --bin: %s\n", err.c_str());
    return 2;
  }

  // --- start-up: static buffers and models
  CoreBuffers buffers;
  if (carve_memory(board, static_arena(), static_arena_bytes(), buffers) != Status::kOk) {
    std::fprintf(stderr, "edgefuse localize: the static arena does not hold board %s's memory map\n", board.name);
    return 1;
  }
  Localizer loc;
  if (loc.init(buffers.localize) != Status::kOk) {
    std::fprintf(stderr, "edgefuse localize: localisation buffers missing in board %s's memory map\n", board.name);
    return 1;
  }
  for (const std::string& f : model_files) {
    int index = -1;
    if (!load_model(loc, f, params, index, err)) {
      std::fprintf(stderr, "edgefuse localize: model %s: %s\n", f.c_str(), err.c_str());
      return 1;
    }
    const ModelInfo& mi = loc.model(index);
    std::printf("model %d: %s, diameter %.1f mm, %u dense samples, %u PPF samples (step %.1f mm), %u table entries\n",
                index, mi.name, mi.diameter_m * 1e3, mi.dense_count, mi.ppf_count, mi.ppf_step_m * 1e3, mi.entry_count);
    std::printf("  %d resting faces (down, object frame):", mi.rest_count);
    for (int k = 0; k < mi.rest_count; ++k)
      std::printf(" (%.2f %.2f %.2f)", mi.rest_down[k].x(), mi.rest_down[k].y(), mi.rest_down[k].z());
    std::printf("\n");
  }

  // Start-up: hypothesis refinement / verification run over --threads workers (same results for any count).
  WorkerPool loc_pool;
  loc_pool.start(fs.threads);
  loc.set_parallel(pool_parallel_for(loc_pool));

  // --- scene
  const std::string input = args.positional()[0];
  SceneContext ctx;
  io::PointCloud in_cloud;  // cloud input (kept for organised label output)
  double t_start_cpu = 0, t_start_proc = 0;  // main thread; all threads
  auto t_start_wall = std::chrono::steady_clock::now();
  CoreSetup core;
  bool fused = false;
  std::size_t surface_count = 0;
  if (args.has("sensors") && args.has("sensor")) {
    std::fprintf(stderr, "edgefuse localize: give --sensor or --sensors, not both\n%s", kUsage);
    return 2;
  }
  if (args.has("sensors")) {  // multi-sensor fusion of a rig set (rig_fusion, as `edgefuse fuse --sensors`)
    io::RigSet set;
    if (!is_dir(input) || !io::open_rig_set(input, set, err)) {
      std::fprintf(stderr, "edgefuse localize: --sensors needs a rig set: %s\n", err.empty() ? input.c_str() : err.c_str());
      return 1;
    }
    RigSensors rs;
    bool usage = false;
    if (!open_rig_sensors(input, set, split_names(args.get("sensors")), board, rs, err, usage)) {
      std::fprintf(stderr, "edgefuse localize: %s\n", err.c_str());
      return usage ? 2 : 1;
    }
    if (rs.ref < 0) {
      std::fprintf(stderr, "edgefuse localize: --sensors needs at least one pinhole camera (the viewpoint)\n");
      return 2;
    }
    int min_weight = 0;
    // fusion5: the noise rules of `fuse --sensors` (fusion_rules.hpp), opt-in here.
    const bool rules = args.has("fusion-rules") && !args.has("no-trust");
    int min_support = -1;  // -1: by set (with --fusion-rules) or off
    float jump_sigmas = rules ? kJumpSigmas : 0.0f;
    if (!args.get_int("min-weight", 0, 255, min_weight, err) || !args.get_int("min-support", 0, 255, min_support, err) ||
        !args.get_float("jump-sigmas", 0.0f, 10.0f, jump_sigmas, err)) {
      std::fprintf(stderr, "edgefuse localize: %s\n", err.c_str());
      return 2;
    }
    if (args.has("no-trust") && (jump_sigmas > 0.0f || args.has("fusion-rules"))) {
      std::fprintf(stderr, "edgefuse localize: --fusion-rules / --jump-sigmas need the noise models (not with --no-trust)\n");
      return 2;
    }
    for (PinholeSlot& c : rs.cams) c.jump_sigmas = jump_sigmas;
    ImageView<uint16_t> filter_scratch;
    if (!core.init(board, rs.cams[std::size_t(rs.ref)].seq.intr, err) ||
        !bind_rig_sensors(rs, core, board, filter_scratch, err) || !place_rig_volume(rs, fs, err) ||
        !core.make_volume(fs, err)) {
      std::fprintf(stderr, "edgefuse localize: %s: %s\n", input.c_str(), err.c_str());
      return 1;
    }
    const std::vector<Pose> mount(rs.cams.size());
    const std::vector<char> mounted(rs.cams.size(), 0);
    // fusion5b: with the rules, sub-unit samples of a mixed set fill a voxel only up to 3 units.
    int sub_unit_fill = kWeightUnitsPerSample;
    if (rules && !plan_sub_unit_fill(rs, !args.has("no-filter"), 0.5f * fs.voxel_m, filter_scratch, sub_unit_fill, err)) {
      std::fprintf(stderr, "edgefuse localize: %s\n", err.c_str());
      return 1;
    }
    if (rules) std::printf("sub-unit fill: samples below half a unit fill a voxel up to %d weight units\n", sub_unit_fill);
    WorkerPool pool;
    pool.start(fs.threads);
    if (!push_rig_frames(rs, core, pool, mount, mounted, std::size_t(frames_max), !args.has("no-filter"), false,
                         args.has("no-trust") ? 0.0f : 0.5f * fs.voxel_m, filter_scratch, err, true)) {
      std::fprintf(stderr, "edgefuse localize: %s\n", err.c_str());
      return 1;
    }
    pool.stop();
    // The viewpoint (visibility of model surface) is the reference camera's mean position.
    const io::DepthSequence& rseq = rs.cams[std::size_t(rs.ref)].seq;
    Vec3f view_sum = Vec3f::Zero();
    std::size_t nv = 0;
    for (std::size_t i = 0; i < std::min<std::size_t>(rseq.frames.size(), std::size_t(frames_max)); ++i)
      if (rseq.frames[i].has_pose) {
        view_sum += rseq.frames[i].T_world_cam.t;
        ++nv;
      }
    ctx.viewpoint_m = view_sum / float(std::max<std::size_t>(nv, 1));
    t_start_cpu = cpu_ms();
    t_start_proc = cpu_ms(CLOCK_PROCESS_CPUTIME_ID);
    t_start_wall = std::chrono::steady_clock::now();
    const std::size_t cap = std::min<std::size_t>(board.points_max, board.scene_points_max);
    if (min_support < 0 && rules) {
      const std::vector<float> sigma = median_sigmas(rs.cams);
      min_support = default_support_weight(sigma.data(), int(sigma.size()), 0.5f * fs.voxel_m, sub_unit_fill);
    }
    if (min_support > 0) std::printf("support rule: both voxels of a crossing hold >= %d weight units\n", min_support);
    const Status xs = extract_points(core.volume, buffers.points, cap, surface_count,
                                     uint8_t(min_support > 0 ? min_support : 0));
    if (min_weight > 0) {  // confidence filter (as `edgefuse fuse --min-weight`): drop weakly supported surface
      std::size_t kept = 0;
      for (std::size_t i = 0; i < surface_count; ++i)
        if (support_weight(core.volume, buffers.points[i].position) >= min_weight) buffers.points[kept++] = buffers.points[i];
      std::printf("confidence filter (--min-weight %d): %zu of %zu surface points kept\n", min_weight, kept, surface_count);
      surface_count = kept;
    }
    const Status ss = loc.set_scene(buffers.points, surface_count, ctx, &core.volume, 3.5f * fs.voxel_m);
    std::printf("fused %s of %s; surface %zu points%s\n", args.get("sensors").c_str(), input.c_str(), surface_count,
                xs == Status::kOutputTruncated || ss == Status::kOutputTruncated ? " (truncated at capacity)" : "");
    fused = true;
  } else if (is_dir(input)) {
    io::DepthSequence seq;
    if (!io::open_depth_sequence(input, args.get("sensor"), seq, err)) {
      std::fprintf(stderr, "edgefuse localize: %s\n", err.c_str());
      return 1;
    }
    const std::size_t frame_count = std::min<std::size_t>(seq.frames.size(), std::size_t(frames_max));
    if (frame_count == 0) {
      std::fprintf(stderr, "edgefuse localize: %s has no frames\n", input.c_str());
      return 1;
    }
    const bool single = seq.frames.size() == 1 && !seq.frames[0].has_pose;
    if (single && !args.has("voxel")) {  // a camera-frame scene ~1 m away: 4 mm voxels span 1 m
      fs.voxel_m = 0.004f;
      fs.trunc_m = 0.016f;
    }
    if (!core.init(board, seq.intr, err)) {
      std::fprintf(stderr, "edgefuse localize: %s: %s\n", input.c_str(), err.c_str());
      return 1;
    }
    std::vector<uint16_t> depth;
    if (!io::load_depth(seq.frames[0], seq.intr, depth, err)) {
      std::fprintf(stderr, "edgefuse localize: %s\n", err.c_str());
      return 1;
    }
    const Pose first = single ? Pose::identity() : seq.frames[0].T_world_cam;
    if (!centre_on_view(seq.intr, depth, first, fs, seq.frames[0].depth_path, err) || !core.make_volume(fs, err)) {
      std::fprintf(stderr, "edgefuse localize: %s: %s\n", input.c_str(), err.c_str());
      return 1;
    }
    WorkerPool pool;
    pool.start(fs.threads);
    Vec3f view_sum = Vec3f::Zero();
    const bool track = args.has("track") && !single;
    // --track: the tracking loop of `edgefuse track` (pre-filters, raycast, pyramid, ICP, push policy).
    FramePyramid<real_t> pyramid;
    IcpWorkspace<real_t> icp_ws;
    DepthFilterChain<real_t> filters;
    ImageView<uint16_t> filter_scratch;
    Tracker tracker;
    int tracked_ok = 0, pushed = 0;
    if (track) {
      if (board.sensors_max < 2 || core.buffers.pyramid<real_t>(0, seq.intr, pyramid) != Status::kOk) {
        std::fprintf(stderr, "edgefuse localize: --track: the board's buffers do not hold this sensor's frame pyramid\n");
        return 1;
      }
      icp_ws = core.buffers.icp_workspace<real_t>(0);
      filters = DepthFilterChain<real_t>::defaults_for(seq.intr, seq.frames[0].amplitude_path.empty()
                                                                      ? DepthSensorKind::kStructuredLight
                                                                      : DepthSensorKind::kTimeOfFlight);
      if (filters.prepare(seq.intr) != Status::kOk) {
        std::fprintf(stderr, "edgefuse localize: --track: depth filters: bad parameters for this sensor\n");
        return 1;
      }
      filter_scratch = ImageView<uint16_t>(core.buffers.depth_frames + std::size_t(board.sensors_max - 1) *
                                                                           core.buffers.pixels_per_sensor,
                                           seq.intr.width, seq.intr.height);
      TrackerParams tp;
      tp.push.every_frame = args.has("push-every-frame");
      if (tracker.start(first, tp) != Status::kOk) {
        std::fprintf(stderr, "edgefuse localize: --track: bad tracker parameters\n");
        return 1;
      }
    }
    for (std::size_t i = 0; i < frame_count && track; ++i) {
      const io::FrameRef& f = seq.frames[i];
      if (i > 0 && !io::load_depth(f, seq.intr, depth, err)) {
        std::fprintf(stderr, "edgefuse localize: %s\n", err.c_str());
        return 1;
      }
      std::vector<uint16_t> amplitude;
      if (!f.amplitude_path.empty() && !io::load_amplitude(f, seq.intr, amplitude, err)) {
        std::fprintf(stderr, "edgefuse localize: %s\n", err.c_str());
        return 1;
      }
      const DepthFrame frame = core.stage_frame(depth, nullptr);
      const ImageView<uint16_t> staged(const_cast<uint16_t*>(frame.depth.data), seq.intr.width, seq.intr.height);
      const ImageView<const uint16_t> amp = amplitude.empty()
                                                ? ImageView<const uint16_t>()
                                                : ImageView<const uint16_t>(amplitude.data(), seq.intr.width, seq.intr.height);
      Status s = filters.run(staged, amp, filter_scratch, staged);
      if (s == Status::kOk && i > 0)
        s = raycast_parallel<real_t>(pool, core.volume, seq.intr, tracker.raycast_pose(), core.maps);
      TrackResult r;
      if (s == Status::kOk) s = build_pyramid<real_t>(frame.depth, PyramidParams(), pyramid);
      if (s == Status::kOk) s = tracker.track<real_t>(pyramid, core.maps, seq.intr, icp_ws, r, nullptr);
      if (s == Status::kOk && r.push)
        s = integrate_parallel<real_t>(pool, core.volume, seq.intr, core.ray_norms, frame, r.T_world_cam, core.scratch);
      if (s != Status::kOk) {
        std::fprintf(stderr, "edgefuse localize: --track: frame %zu (%s): %s\n", i, f.depth_path.c_str(), to_string(s));
        return 1;
      }
      tracked_ok += r.state == TrackState::kOk;
      pushed += r.push;
      view_sum += r.T_world_cam.t;
      if (f.has_pose && i + 1 == frame_count)
        std::printf("tracked %zu frames (%d ok, %d pushed); last pose %.2f mm from the set's ground truth\n",
                    frame_count, tracked_ok, pushed, (r.T_world_cam.t - f.T_world_cam.t).norm() * 1e3);
    }
    for (std::size_t i = 0; i < frame_count && !track; ++i) {
      const io::FrameRef& f = seq.frames[i];
      if (!single && !f.has_pose) {
        std::fprintf(stderr, "edgefuse localize: %s: frame %zu has no ground-truth pose\n", input.c_str(), i);
        return 1;
      }
      if (i > 0 && !io::load_depth(f, seq.intr, depth, err)) {
        std::fprintf(stderr, "edgefuse localize: %s\n", err.c_str());
        return 1;
      }
      const DepthFrame frame = core.stage_frame(depth, nullptr);
      const Pose T = single ? Pose::identity() : f.T_world_cam;
      view_sum += T.t;
      const Status s = integrate_parallel<real_t>(pool, core.volume, seq.intr, core.ray_norms, frame, T, core.scratch);
      if (s != Status::kOk) {
        std::fprintf(stderr, "edgefuse localize: frame %zu: %s\n", i, to_string(s));
        return 1;
      }
    }
    pool.stop();
    ctx.viewpoint_m = view_sum / float(frame_count);
    // The clock of the pose list starts after the last integrated frame.
    t_start_cpu = cpu_ms();
    t_start_proc = cpu_ms(CLOCK_PROCESS_CPUTIME_ID);
    t_start_wall = std::chrono::steady_clock::now();
    std::size_t cap = std::min<std::size_t>(board.points_max, board.scene_points_max);
    const Status xs = extract_points(core.volume, buffers.points, cap, surface_count);
    // Grid cell 3.5 voxels: measured fastest of 1.5 / 2.5 / 3.5 / 5 voxels on bin_rig_a, same poses.
    const Status ss = loc.set_scene(buffers.points, surface_count, ctx, &core.volume, 3.5f * fs.voxel_m);
    std::printf("fused %zu frames of %s (%s); surface %zu points%s\n", frame_count, input.c_str(),
                seq.sensor_name.c_str(), surface_count,
                xs == Status::kOutputTruncated || ss == Status::kOutputTruncated ? " (truncated at capacity)" : "");
    fused = true;
  } else {
    // The readers' messages begin with the file's name (and line); only the extension test needs it added.
    if (!(ends_with(input, ".pcd") ? io::read_pcd(input, in_cloud, err) : ends_with(input, ".ply")
                                                                              ? io::read_ply(input, in_cloud, err)
                                                                              : (err = input + ": expected a folder, .ply or .pcd", false))) {
      std::fprintf(stderr, "edgefuse localize: %s\n", err.c_str());
      return 1;
    }
    std::vector<ScenePoint> pts;
    const double t_normals = cpu_ms();  // normals of a cloud are not part of the pose-list clock: own figure
    std::size_t beyond = 0;
    if (!cloud_scene_points(in_cloud, pts, beyond, err)) {
      std::fprintf(stderr, "edgefuse localize: %s: %s\n", input.c_str(), err.c_str());
      return 1;
    }
    if (beyond > 0)
      std::fprintf(stderr, "edgefuse localize: %s: %zu points lie beyond %.0f m of the origin (not a robot cell's "
                   "coordinates): ignored\n", input.c_str(), beyond, double(kLocalizeCoordMaxM));
    std::printf("normals_cpu_ms=%.1f (cloud normals and scene points, before the localisation clock starts)\n",
                cpu_ms() - t_normals);
    ctx.viewpoint_m = Vec3f::Zero();  // a cloud is in its camera's frame
    t_start_cpu = cpu_ms();
    t_start_proc = cpu_ms(CLOCK_PROCESS_CPUTIME_ID);
    t_start_wall = std::chrono::steady_clock::now();
    const Status ss = loc.set_scene_points(pts.data(), pts.size(), ctx, nullptr, 0.005f);
    std::printf("cloud %s: %zu points (%dx%d), %zu with normals%s\n", input.c_str(), in_cloud.size(), in_cloud.width,
                in_cloud.height, pts.size(), ss == Status::kOutputTruncated ? " (truncated at capacity)" : "");
  }
  (void)fused;
  const std::size_t before = loc.scene_count();
  if (bin_from_config) loc.set_bin(bin_config, params);  // validated when read
  else loc.remove_bin(params);
  const SceneContext& c = loc.context();
  std::printf("bin: %s, %d walls; %zu of %zu scene points left\n",
              bin_from_config ? "from configuration" : c.has_floor ? "floor found" : "no floor", c.walls,
              loc.scene_count(), before);
  if (c.has_floor)
    std::printf("floor: up %.3f %.3f %.3f offset %.4f, centre %.3f %.3f %.3f, extent %.3f..%.3f along (%.2f %.2f %.2f), "
                "%.3f..%.3f along (%.2f %.2f %.2f)\n",
                c.up.x(), c.up.y(), c.up.z(), c.floor_offset, c.floor_centre_m.x(), c.floor_centre_m.y(),
                c.floor_centre_m.z(), c.floor_lo[0], c.floor_hi[0], c.floor_axis[0].x(), c.floor_axis[0].y(),
                c.floor_axis[0].z(), c.floor_lo[1], c.floor_hi[1], c.floor_axis[1].x(), c.floor_axis[1].y(),
                c.floor_axis[1].z());
  if (args.has("scene-out")) {  // diagnostics: the scene the matcher sees
    io::PointCloud sc;
    for (std::size_t i = 0; i < loc.scene_count(); ++i) {
      sc.points.push_back(loc.scene()[i].p);
      sc.normals.push_back(loc.scene()[i].n);
    }
    sc.width = int(sc.points.size());
    if (!write_cloud(args.get("scene-out"), sc, err)) {
      std::fprintf(stderr, "edgefuse localize: %s\n", err.c_str());
      return 1;
    }
  }
  std::size_t count = 0;
  const Status ls = segments ? loc.segment(params, max_results, count) : loc.localize(params, max_results, count);
  const double ms_cpu = cpu_ms() - t_start_cpu;
  const double ms_proc = cpu_ms(CLOCK_PROCESS_CPUTIME_ID) - t_start_proc;
  const double ms_wall = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t_start_wall).count();
  if (ls != Status::kOk) {
    std::fprintf(stderr, "edgefuse localize: %s\n", to_string(ls));
    return 1;
  }
  const LocalizedObject* r = loc.results();
  for (std::size_t i = 0; i < count; ++i) {
    const Eigen::Quaternionf q = r[i].T_world_object.quaternion();
    const Vec3f& t = r[i].T_world_object.t;
    std::printf("%zu %s t %.4f %.4f %.4f q %.5f %.5f %.5f %.5f score %.3f support %u residual %.2f mm free %.3f "
                "top %.1f mm grasp %.4f %.4f %.4f approach %.3f %.3f %.3f size %.1f %.1f %.1f mm\n",
                i + 1, segments ? "segment" : loc.model(r[i].model).name, t.x(), t.y(), t.z(), q.x(), q.y(), q.z(),
                q.w(), r[i].score, r[i].support, r[i].residual_m * 1e3, r[i].free_space, r[i].top_m * 1e3,
                r[i].grasp_m.x(), r[i].grasp_m.y(), r[i].grasp_m.z(), r[i].approach.x(), r[i].approach.y(),
                r[i].approach.z(), r[i].size_m.x() * 1e3, r[i].size_m.y() * 1e3, r[i].size_m.z() * 1e3);
  }
  std::printf("%s=%zu candidates=%zu localize_cpu_ms=%.1f localize_proc_cpu_ms=%.1f localize_wall_ms=%.1f\n",
              segments ? "segments" : "objects", count, loc.last_candidates(), ms_cpu, ms_proc, ms_wall);
  if (args.has("check-truth") && !segments) {  // diagnostics: the true poses through the same verification
    io::RigSet set;
    if (!is_dir(input) || !io::open_rig_set(input, set, err)) {
      std::fprintf(stderr, "edgefuse localize: --check-truth needs a rig set: %s\n", err.empty() ? input.c_str() : err.c_str());
      return 1;
    }
    for (const io::ObjectPose& o : set.objects) {
      const io::RigObject* ro = set.rig.find_object(o.id);
      if (!ro) continue;
      const std::string base = ro->model.substr(ro->model.find_last_of('/') + 1);
      for (int m = 0; m < loc.model_count(); ++m) {
        if (base != loc.model(m).name) continue;
        LocalizedObject at, refined;
        loc.check_pose(m, o.T_world_object, params, false, at);
        const bool ok = loc.check_pose(m, o.T_world_object, params, true, refined);
        const Pose d = o.T_world_object.inverse() * refined.T_world_object;
        const float ang = std::acos(std::min(1.0f, std::max(-1.0f, 0.5f * (d.R.trace() - 1.0f)))) * 57.29578f;
        std::printf("truth %d %s: at truth score %.3f support %u residual %.2f mm free %.3f; after ICP%s score %.3f "
                    "support %u free %.3f moved %.2f mm %.2f deg\n",
                    o.id, base.c_str(), at.score, at.support, at.residual_m * 1e3, at.free_space, ok ? "" : " (failed)",
                    refined.score, refined.support, refined.free_space,
                    (refined.T_world_object.t - o.T_world_object.t).norm() * 1e3, ang);
      }
    }
  }
  if (segments) {
    const std::string out = args.get("out", "labels.pcd");
    if (!write_segment_labels(out, loc, in_cloud, surface_count, buffers.points, err)) {
      std::fprintf(stderr, "edgefuse localize: %s\n", err.c_str());
      return 1;
    }
    std::printf("labels -> %s\n", out.c_str());
  } else if (args.has("out")) {
    if (!write_pose_list(args.get("out"), loc, count, err)) {
      std::fprintf(stderr, "edgefuse localize: %s\n", err.c_str());
      return 1;
    }
    std::printf("poses -> %s\n", args.get("out").c_str());
  }
  return 0;
}

}  // namespace edgefuse::cli
