// edgefuse fuse: integrates a depth sequence at its ground-truth poses and writes the fused cloud
// (and optionally the mesh). The main job of tools/run until the runtime daemon exists.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "args.hpp"
#include "commands.hpp"
#include "core_setup.hpp"
#include "fuse_options.hpp"
#include "edgefuse/io/dataset.hpp"
#include "edgefuse/io/mesh_collector.hpp"
#include "edgefuse/tsdf/extract.hpp"
#include "edgefuse/hal/platform/threads/parallel_tsdf.hpp"

namespace edgefuse::cli {
namespace {

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

const char* kUsage =
    "usage: edgefuse fuse DATASET [--sensor NAME] [--frames N] [--voxel M] [--trunc M] [--volume N]\n"
    "                     [--origin X,Y,Z] [--out FILE.ply|.pcd] [--mesh FILE.ply] [--threads N]\n"
    "  Integrates the frames of DATASET (any layout of FORMATS.md) at their ground-truth poses.\n"
    "  Defaults: voxel, truncation and threads from the board; volume = the board's capacity,\n"
    "  centred on what the first frame sees; --out fused.ply.\n"
    "  With --sensors A,B,... (a rig set): several sensors into one space; see `edgefuse fuse RIGSET --sensors`.\n";

}  // namespace

int cmd_fuse(int argc, char** argv) {
  // Several sensors of a rig set into one space (issue 4): its own option set.
  for (int i = 0; i < argc; ++i)
    if (std::string(argv[i]) == "--sensors") return cmd_fuse_rig(argc, argv);
  Args args;
  std::string err;
  if (!args.parse(argc, argv, {"sensor", "frames", "voxel", "trunc", "volume", "origin", "out", "mesh", "threads"},
                  {}, err) ||
      args.positional().size() != 1) {
    std::fprintf(stderr, "edgefuse fuse: %s\n%s", err.empty() ? "expected one DATASET" : err.c_str(), kUsage);
    return 2;
  }
  const BoardCapacities& board = build_board();
  FuseSettings settings;
  if (!board_fuse_settings(settings, err)) {
    std::fprintf(stderr, "edgefuse fuse: %s\n", err.c_str());
    return 1;
  }
  int frames_max = 0;
  if (!apply_fuse_options(args, settings, frames_max, err)) {
    std::fprintf(stderr, "edgefuse fuse: %s\n", err.c_str());
    return 2;
  }

  io::DepthSequence seq;
  if (!io::open_depth_sequence(args.positional()[0], args.get("sensor"), seq, err)) {
    std::fprintf(stderr, "edgefuse fuse: %s\n", err.c_str());
    return 1;
  }
  const std::size_t frame_count = std::min<std::size_t>(seq.frames.size(), std::size_t(frames_max));
  if (frame_count == 0) {
    std::fprintf(stderr, "edgefuse fuse: %s has no frames\n", seq.root.c_str());
    return 1;
  }
  const bool single_unposed = seq.frames.size() == 1 && !seq.frames[0].has_pose;
  for (std::size_t i = 0; i < frame_count && !single_unposed; ++i)
    if (!seq.frames[i].has_pose) {
      std::fprintf(stderr, "edgefuse fuse: %s: frame %zu (%s) has no ground-truth pose; fuse needs one per frame\n",
                   seq.root.c_str(), i, seq.frames[i].depth_path.c_str());
      return 1;
    }

  CoreSetup core;
  if (!core.init(board, seq.intr, err)) {
    std::fprintf(stderr, "edgefuse fuse: %s: %s\n", seq.root.c_str(), err.c_str());
    return 1;
  }
  std::printf("edgefuse fuse: %s (%s, sensor %s), %zu of %zu frames, %dx%d fx %.1f fy %.1f, depth scale %.0f%s\n",
              seq.root.c_str(), io::to_string(seq.layout), seq.sensor_name.c_str(), frame_count, seq.frames.size(),
              seq.intr.width, seq.intr.height, seq.intr.fx, seq.intr.fy, seq.intr.depth_scale,
              seq.colour_registered ? ", registered colour" : "");

  // First frame: needed for the default volume placement.
  std::vector<uint16_t> depth;
  std::vector<Rgb8> colour;
  const Pose first_pose = single_unposed ? Pose::identity() : seq.frames[0].T_world_cam;
  if (!io::load_depth(seq.frames[0], seq.intr, depth, err)) {
    std::fprintf(stderr, "edgefuse fuse: %s\n", err.c_str());
    return 1;
  }
  if (!settings.origin_given && !centre_on_view(seq.intr, depth, first_pose, settings, seq.frames[0].depth_path, err)) {
    std::fprintf(stderr, "edgefuse fuse: %s\n", err.c_str());
    return 1;
  }
  if (!core.make_volume(settings, err)) {
    std::fprintf(stderr, "edgefuse fuse: %s\n", err.c_str());
    return 1;
  }
  const Vec3f& o = core.volume.origin_m();
  std::printf("volume: %d^3 voxels of %.4f m (%.3f m), origin %.4f,%.4f,%.4f, trunc %.4f m, %s, %s kernels, %d threads, "
              "board %s\n",
              settings.dim, settings.voxel_m, settings.dim * settings.voxel_m, o.x(), o.y(), o.z(), settings.trunc_m,
              core.volume.has_colour() ? "colour" : "no colour", kFixedPointBuild ? "fixed-point" : "float",
              settings.threads, board.name);

  WorkerPool pool;
  pool.start(settings.threads);
  const bool use_colour = seq.colour_registered && core.volume.has_colour();
  double integrate_ms = 0, raycast_ms = 0;
  for (std::size_t i = 0; i < frame_count; ++i) {
    const io::FrameRef& f = seq.frames[i];
    if (i > 0 && !io::load_depth(f, seq.intr, depth, err)) {
      std::fprintf(stderr, "edgefuse fuse: %s\n", err.c_str());
      return 1;
    }
    if (use_colour && !f.colour_path.empty() && !io::load_colour(f, seq.intr, colour, err)) {
      std::fprintf(stderr, "edgefuse fuse: %s\n", err.c_str());
      return 1;
    }
    const DepthFrame frame = core.stage_frame(depth, use_colour && !f.colour_path.empty() ? &colour : nullptr);
    const Pose T = single_unposed ? Pose::identity() : f.T_world_cam;
    auto t0 = std::chrono::steady_clock::now();
    Status s = integrate_parallel<real_t>(pool, core.volume, seq.intr, core.ray_norms, frame, T, core.scratch);
    const double ti = ms_since(t0);
    t0 = std::chrono::steady_clock::now();
    if (s == Status::kOk) s = raycast_parallel<real_t>(pool, core.volume, seq.intr, T, core.maps);
    const double tr = ms_since(t0);
    if (s != Status::kOk) {
      std::fprintf(stderr, "edgefuse fuse: frame %zu (%s): %s\n", i, f.depth_path.c_str(), to_string(s));
      return 1;
    }
    integrate_ms += ti;
    raycast_ms += tr;
    if (i == 0 || (i + 1) % 10 == 0 || i + 1 == frame_count)
      std::printf("frame %zu/%zu stamp %.6f: integrate %.2f ms, raycast %.2f ms, %d%% of pixels hit the model\n", i + 1,
                  frame_count, f.stamp_s, ti, tr, core.hit_percent(seq.intr));
  }
  pool.stop();

  const std::size_t voxels = core.volume.observed_voxels();
  auto t0 = std::chrono::steady_clock::now();
  io::PointCloud cloud;
  const Status xs = core.extract_cloud(cloud);
  const std::string out = args.get("out", "fused.ply");
  if (!write_cloud(out, cloud, err)) {
    std::fprintf(stderr, "edgefuse fuse: %s\n", err.c_str());
    return 1;
  }
  std::printf("cloud: %zu points%s -> %s (%.1f ms)\n", cloud.size(),
              xs == Status::kOutputTruncated ? " (truncated at the board's point capacity)" : "", out.c_str(),
              ms_since(t0));
  if (args.has("mesh")) {
    t0 = std::chrono::steady_clock::now();
    io::PlyMeshCollector mesh;
    const Status ms = extract_mesh(core.volume, core.buffers.mesh_scratch, mesh);
    if (ms != Status::kOk || !mesh.write(args.get("mesh"), err)) {
      std::fprintf(stderr, "edgefuse fuse: mesh: %s\n", ms != Status::kOk ? to_string(ms) : err.c_str());
      return 1;
    }
    std::printf("mesh: %zu vertices, %zu triangles -> %s (%.1f ms)\n", mesh.mesh().vertices.size(),
                mesh.mesh().triangles.size(), args.get("mesh").c_str(), ms_since(t0));
  }
  std::printf("frames=%zu integrate_ms=%.3f raycast_ms=%.3f voxels=%zu\n", frame_count,
              integrate_ms / double(frame_count), raycast_ms / double(frame_count), voxels);
  return 0;
}

}  // namespace edgefuse::cli
