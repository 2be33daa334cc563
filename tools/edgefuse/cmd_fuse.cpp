// edgefuse fuse: integrates a depth sequence at its ground-truth poses and writes the fused cloud
// (and optionally the mesh). The main job of tools/run until the runtime daemon exists.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "failure.hpp"
#include "args.hpp"
#include "commands.hpp"
#include "core_setup.hpp"
#include "fuse_options.hpp"
#include "edgefuse/io/dataset.hpp"
#include "edgefuse/io/mesh_collector.hpp"
#include "edgefuse/tsdf/extract.hpp"
#include "edgefuse/pipeline/mapper.hpp"

namespace edgefuse::cli {
namespace {


const char* kUsage =
    "usage: edgefuse fuse DATASET [--sensor NAME] [--frames N] [--voxel M] [--trunc M] [--volume N]\n"
    "                     [--origin X,Y,Z] [--out FILE.ply|.pcd] [--mesh FILE.ply] [--threads N]\n"
    "  Integrates the frames of DATASET (any layout of FORMATS.md) at their ground-truth poses.\n"
    "  Defaults: voxel, truncation, volume (voxels per axis) and threads from the board's [tsdf],\n"
    "  centred on what the first frame sees; --out fused.ply. Without --voxel, --volume and --origin,\n"
    "  when that space holds less than 90 % of the first frame's points, it grows to the board's\n"
    "  capacity per axis, then the voxel grows (4 mm, 5 mm, 1 cm, 2 cm) until it does, and a line\n"
    "  says so; an explicit space is kept (a warning when it holds less than half).\n"
    "  With --sensors A,B,... (a rig set): several sensors into one space; see `edgefuse fuse RIGSET --sensors`.\n";

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}



// What the command line asks for.
struct FuseOptions {
  Args args;
  FuseSettings settings;
  int frames_max = 0;
};

bool parse_options(int argc, char** argv, FuseOptions& o, Failure& f) {
  std::string err;
  if (!o.args.parse(argc, argv, {"sensor", "frames", "voxel", "trunc", "volume", "origin", "out", "mesh", "threads"},
                    {}, err) ||
      o.args.positional().size() != 1) {
    f.usage = true;
    return fail(f, err.empty() ? "expected one DATASET" : err, 2);
  }
  if (!board_fuse_settings(o.settings, err)) return fail(f, err);
  if (!apply_fuse_options(o.args, o.settings, o.frames_max, err)) return fail(f, err, 2);
  return true;
}

// The sequence and the core it is fused in.
struct FuseRun {
  io::DepthSequence seq;
  std::size_t frame_count = 0;
  bool single_unposed = false;  // one frame without a pose: fused at the identity
  CoreSetup core;
  std::vector<uint16_t> depth;  // the frame being fused (the first one once the volume is placed)
  std::vector<Rgb8> colour;
};

bool open_sequence(const FuseOptions& o, FuseRun& run, Failure& f) {
  io::DepthSequence& seq = run.seq;
  std::string err;
  if (!io::open_depth_sequence(o.args.positional()[0], o.args.get("sensor"), seq, err)) return fail(f, err);
  run.frame_count = std::min<std::size_t>(seq.frames.size(), std::size_t(o.frames_max));
  if (run.frame_count == 0) return fail(f, seq.root + " has no frames");
  run.single_unposed = seq.frames.size() == 1 && !seq.frames[0].has_pose;
  for (std::size_t i = 0; i < run.frame_count && !run.single_unposed; ++i)
    if (!seq.frames[i].has_pose) {
      return fail(f, seq.root + ": frame " + std::to_string(i) + " (" + seq.frames[i].depth_path + ") has no ground-truth pose; fuse needs one per frame");
    }
  return true;
}

// The core's buffers, then the volume: placed by --origin or centred on what the first frame sees.
bool set_up_core(FuseOptions& o, FuseRun& run, Failure& f) {
  const BoardCapacities& board = build_board();
  const io::DepthSequence& seq = run.seq;
  FuseSettings& settings = o.settings;
  CoreSetup& core = run.core;
  std::string err;
  if (!core.init(board, seq.intr, err)) return fail(f, seq.root + ": " + err);
  std::printf("edgefuse fuse: %s (%s, sensor %s), %zu of %zu frames, %dx%d fx %.1f fy %.1f, depth scale %.0f%s\n",
              seq.root.c_str(), io::to_string(seq.layout), seq.sensor_name.c_str(), run.frame_count,
              seq.frames.size(), seq.intr.width, seq.intr.height, seq.intr.fx, seq.intr.fy, seq.intr.depth_scale,
              seq.colour_registered ? ", registered colour" : "");
  // First frame: needed for the default volume placement.
  const Pose first_pose = run.single_unposed ? Pose::identity() : seq.frames[0].T_world_cam;
  if (!io::load_depth(seq.frames[0], seq.intr, run.depth, err)) return fail(f, err);
  if (!size_space_to_view("fuse", seq.intr, run.depth, first_pose, settings, seq.frames[0].depth_path, err))
    return fail(f, err);
  if (!core.make_volume(settings, err)) return fail(f, err);
  const Vec3f& org = core.volume.origin_m();
  std::printf("volume: %d^3 voxels of %.4f m (%.3f m), origin %.4f,%.4f,%.4f, trunc %.4f m, %s, %s kernels, %d threads, "
              "board %s\n",
              settings.dim, settings.voxel_m, settings.dim * settings.voxel_m, org.x(), org.y(), org.z(),
              settings.trunc_m, core.volume.has_colour() ? "colour" : "no colour",
              kFixedPointBuild ? "fixed-point" : "float", settings.threads, board.name);
  return true;
}

// Per-frame times, summed over the frames.
struct FuseTimes {
  double integrate_ms = 0, raycast_ms = 0;
};

// Frame i: loaded (frame 0 already is), mapped at its pose, the model raycast from it.
bool fuse_frame(FuseRun& run, std::size_t i, const PoolRunners& threads, CameraSlot& cam, Mapper& mapper,
                FuseTimes& times, Failure& f) {
  const io::DepthSequence& seq = run.seq;
  CoreSetup& core = run.core;
  const io::FrameRef& fr = seq.frames[i];
  const bool use_colour = seq.colour_registered && core.volume.has_colour();
  std::string err;
  if (i > 0 && !io::load_depth(fr, seq.intr, run.depth, err)) return fail(f, err);
  if (use_colour && !fr.colour_path.empty() && !io::load_colour(fr, seq.intr, run.colour, err)) return fail(f, err);
  const DepthFrame staged = core.stage_frame(run.depth, use_colour && !fr.colour_path.empty() ? &run.colour : nullptr);
  SensorFrame frame;
  frame.depth = staged.depth;
  frame.colour = staged.colour;
  const Pose T = run.single_unposed ? Pose::identity() : fr.T_world_cam;
  auto t0 = std::chrono::steady_clock::now();
  ReferenceStep step;
  Status s = mapper.map_reference(cam, frame, &T, T, step);
  const double ti = ms_since(t0);
  t0 = std::chrono::steady_clock::now();
  if (s == Status::kOk) s = raycast_frame<real_t>(threads.runners().tsdf, core.volume, seq.intr, T, cam.maps);
  const double tr = ms_since(t0);
  if (s != Status::kOk) return fail(f, "frame " + std::to_string(i) + " (" + fr.depth_path + "): " + to_string(s));
  times.integrate_ms += ti;
  times.raycast_ms += tr;
  if (i == 0 || (i + 1) % 10 == 0 || i + 1 == run.frame_count)
    std::printf("frame %zu/%zu stamp %.6f: integrate %.2f ms, raycast %.2f ms, %d%% of pixels hit the model\n", i + 1,
                run.frame_count, fr.stamp_s, ti, tr, CoreSetup::hit_percent(cam.maps));
  return true;
}

// The frames enter the map through the pipeline's mapping step at their recorded poses, as
// recorded (no pre-filters): what the sensor measured, fused.
bool fuse_frames(const FuseOptions& o, FuseRun& run, FuseTimes& times, Failure& f) {
  const io::DepthSequence& seq = run.seq;
  CoreSetup& core = run.core;
  std::string err;
  PoolRunners threads;
  threads.start(o.settings.threads);
  MapperParams mp;
  mp.prefilter = false;
  CameraSlot cam;
  Mapper mapper;
  if (!core.bind_camera(cam, 0, seq.intr, DepthSensorKind::kStructuredLight, false, true, err) ||
      mapper.init(core.volume, threads.runners(), core.spare_image(seq.intr.width, seq.intr.height),
                  core.centre_scratch(seq.intr), mp) != Status::kOk)
    return fail(f, seq.root + ": " + (err.empty() ? "mapping refused" : err));
  mapper.new_map_in_place();
  for (std::size_t i = 0; i < run.frame_count; ++i)
    if (!fuse_frame(run, i, threads, cam, mapper, times, f)) return false;
  threads.pool.stop();
  return true;
}

// The cloud (and the mesh), then the summary line.
bool write_outputs(const FuseOptions& o, const FuseRun& run, const FuseTimes& times, Failure& f) {
  const CoreSetup& core = run.core;
  std::string err;
  const std::size_t voxels = core.volume.observed_voxels();
  auto t0 = std::chrono::steady_clock::now();
  io::PointCloud cloud;
  const Status xs = core.extract_cloud(cloud);
  const std::string out = o.args.get("out", "fused.ply");
  if (!write_cloud(out, cloud, err)) return fail(f, err);
  std::printf("cloud: %zu points%s -> %s (%.1f ms)\n", cloud.size(),
              xs == Status::kOutputTruncated ? " (truncated at the board's point capacity)" : "", out.c_str(),
              ms_since(t0));
  if (o.args.has("mesh")) {
    t0 = std::chrono::steady_clock::now();
    io::PlyMeshCollector mesh;
    const Status ms = extract_mesh(core.volume, core.buffers.mesh_scratch, mesh);
    if (ms != Status::kOk || !mesh.write(o.args.get("mesh"), err))
      return fail(f, std::string("mesh: ") + (ms != Status::kOk ? to_string(ms) : err.c_str()));
    std::printf("mesh: %zu vertices, %zu triangles -> %s (%.1f ms)\n", mesh.mesh().vertices.size(),
                mesh.mesh().triangles.size(), o.args.get("mesh").c_str(), ms_since(t0));
  }
  std::printf("%s\n", core.space_usage().c_str());
  const double n = double(run.frame_count);
  std::printf("frames=%zu integrate_ms=%.3f raycast_ms=%.3f voxels=%zu\n", run.frame_count, times.integrate_ms / n,
              times.raycast_ms / n, voxels);
  return true;
}

}  // namespace

int cmd_fuse(int argc, char** argv) {
  // Several sensors of a rig set into one space: its own option set.
  for (int i = 0; i < argc; ++i)
    if (std::string(argv[i]) == "--sensors") return cmd_fuse_rig(argc, argv);
  if (help_asked(argc, argv, kUsage)) return 0;
  FuseOptions o;
  Failure f;
  FuseRun run;
  FuseTimes times;
  if (!parse_options(argc, argv, o, f) || !open_sequence(o, run, f) || !set_up_core(o, run, f) ||
      !fuse_frames(o, run, times, f) || !write_outputs(o, run, times, f))
    return report("edgefuse fuse", f, kUsage);
  return 0;
}

}  // namespace edgefuse::cli
