// edgefuse track: the paper's Fig. 3 loop on a recorded sequence. Per frame: pre-filter the depth,
// raycast the model at the current pose, align the frame by ICP, classify the tracking state,
// decide whether to push, integrate. Writes the estimated trajectory (TUM format, sensor-to-world)
// and optionally the fused cloud; the last line is machine-readable.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <ctime>
#include <cstdio>
#include <string>
#include <vector>

#include "args.hpp"
#include "commands.hpp"
#include "core_setup.hpp"
#include "fuse_options.hpp"
#include "edgefuse/filters/depth_filter_chain.hpp"
#include "edgefuse/io/dataset.hpp"
#include "edgefuse/io/trajectory.hpp"
#include "edgefuse/tracking/tracker.hpp"
#include "edgefuse/hal/platform/threads/parallel_tsdf.hpp"
#include "edgefuse/hal/platform/threads/pool_row_runner.hpp"

namespace edgefuse::cli {
namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }
// CPU time of the whole process (all threads) in ms: on a shared machine, wall time also counts
// the time other processes held the cores; CPU time does not.
double cpu_ms() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) * 1e3 + double(ts.tv_nsec) * 1e-6;
}

const char* kUsage =
    "usage: edgefuse track DATASET [--sensor NAME] [--frames N] [--out traj.txt] [--cloud FILE.ply|.pcd]\n"
    "                      [--voxel M] [--trunc M] [--volume N] [--threads N] [--push-every-frame]\n"
    "  Tracks the sensor through DATASET (any layout of FORMATS.md) by ICP against the fused model and\n"
    "  fuses the frames at the estimated poses. The first pose is the data set's first ground-truth\n"
    "  pose, or the identity without one. Defaults: voxel, truncation and threads from the board (4\n"
    "  voxels of truncation when only --voxel is given); volume = the board's capacity, centred on\n"
    "  what the first frame sees; --out track.txt. Frames are pushed when the sensor moved 1 cm or\n"
    "  1 degree since the last push (--push-every-frame: always), never while tracking is lost.\n";

struct Totals {
  double filter = 0, raycast = 0, icp = 0, integrate = 0, loop = 0;
  double cpu[5] = {};  // the same phases in process CPU time
  int ok = 0, degraded = 0, lost = 0, pushed = 0;
};

int fail(const std::string& msg) {
  std::fprintf(stderr, "edgefuse track: %s\n", msg.c_str());
  return 1;
}

}  // namespace

int cmd_track(int argc, char** argv) {
  Args args;
  std::string err;
  if (!args.parse(argc, argv, {"sensor", "frames", "out", "cloud", "voxel", "trunc", "volume", "threads"},
                  {"push-every-frame"}, err) ||
      args.positional().size() != 1) {
    std::fprintf(stderr, "edgefuse track: %s\n%s", err.empty() ? "expected one DATASET" : err.c_str(), kUsage);
    return 2;
  }
  const BoardCapacities& board = build_board();
  FuseSettings settings;
  if (!board_fuse_settings(settings, err)) return fail(err);
  int frames_max = 0;
  if (!apply_fuse_options(args, settings, frames_max, err)) {  // no --origin: centred on the first view
    std::fprintf(stderr, "edgefuse track: %s\n", err.c_str());
    return 2;
  }
  if (board.sensors_max < 2) return fail("board " + std::string(board.name) + " has no spare frame buffer for filtering");

  io::DepthSequence seq;
  if (!io::open_depth_sequence(args.positional()[0], args.get("sensor"), seq, err)) return fail(err);
  const std::size_t frame_count = std::min<std::size_t>(seq.frames.size(), std::size_t(frames_max));
  if (frame_count == 0) return fail(seq.root + " has no frames");
  const PinholeIntrinsics& intr = seq.intr;

  CoreSetup core;
  if (!core.init(board, intr, err)) return fail(seq.root + ": " + err);
  FramePyramid<real_t> pyramid;
  if (core.buffers.pyramid<real_t>(0, intr, pyramid) != Status::kOk)
    return fail("the frame pyramid does not fit the board's buffers (image too small or too large)");
  const IcpWorkspace<real_t> icp_ws = core.buffers.icp_workspace<real_t>(0);

  // Pre-filters (structured light or ToF by whether the sequence has amplitude images). The chain
  // filters in place; its intermediate image uses the frame buffer of the last sensor slot, which
  // this single-sensor command does not otherwise use.
  const bool tof = !seq.frames[0].amplitude_path.empty();
  DepthFilterChain<real_t> filters = DepthFilterChain<real_t>::defaults_for(
      intr, tof ? DepthSensorKind::kTimeOfFlight : DepthSensorKind::kStructuredLight);
  if (filters.prepare(intr) != Status::kOk) return fail("depth filters: bad parameters for this sensor");
  const ImageView<uint16_t> filter_scratch(
      core.buffers.depth_frames + std::size_t(board.sensors_max - 1) * core.buffers.pixels_per_sensor, intr.width,
      intr.height);

  const Pose first_pose = seq.frames[0].has_pose ? seq.frames[0].T_world_cam : Pose::identity();
  std::vector<uint16_t> depth, amplitude;
  std::vector<Rgb8> colour;
  if (!io::load_depth(seq.frames[0], intr, depth, err)) return fail(err);
  if (!centre_on_view(intr, depth, first_pose, settings, seq.frames[0].depth_path, err)) return fail(err);
  if (!core.make_volume(settings, err)) return fail(err);

  TrackerParams params;
  params.push.every_frame = args.has("push-every-frame");
  Tracker tracker;
  if (tracker.start(first_pose, params) != Status::kOk) return fail("bad tracker parameters");

  const Vec3f& o = core.volume.origin_m();
  std::printf("edgefuse track: %s (%s, sensor %s), %zu of %zu frames, %dx%d fx %.1f fy %.1f, %s filters\n",
              seq.root.c_str(), io::to_string(seq.layout), seq.sensor_name.c_str(), frame_count, seq.frames.size(),
              intr.width, intr.height, intr.fx, intr.fy, tof ? "time-of-flight" : "structured-light");
  std::printf("volume: %d^3 voxels of %.4f m, origin %.4f,%.4f,%.4f, trunc %.4f m, %s kernels, %d threads; "
              "first pose from %s; push %s\n",
              settings.dim, settings.voxel_m, o.x(), o.y(), o.z(), settings.trunc_m,
              kFixedPointBuild ? "fixed-point" : "float", settings.threads,
              seq.frames[0].has_pose ? "ground truth" : "identity",
              params.push.every_frame ? "every frame" : "after 1 cm / 1 deg");

  WorkerPool pool;
  pool.start(settings.threads);
  PoolRowRunner pool_rows(pool);  // ICP rows over the pool (hal/os)
  const RowRunner* rows = settings.threads > 1 ? pool_rows.runner() : nullptr;

  const bool use_colour = seq.colour_registered && core.volume.has_colour();
  // The model ICP registers against: depth, vertex and normal maps. ICP reads no colour, so the
  // tracking raycast skips the colour map (7 % of a 320x240 raycast's instructions).
  RaycastMaps model = core.maps;
  model.colour = ImageView<Rgba8>();
  std::vector<io::StampedPose> trajectory;
  trajectory.reserve(frame_count);
  Totals sum;
  for (std::size_t i = 0; i < frame_count; ++i) {
    const io::FrameRef& f = seq.frames[i];
    if (i > 0 && !io::load_depth(f, intr, depth, err)) return fail(err);
    if (use_colour && !f.colour_path.empty() && !io::load_colour(f, intr, colour, err)) return fail(err);
    if (tof && !f.amplitude_path.empty() && !io::load_amplitude(f, intr, amplitude, err)) return fail(err);
    const DepthFrame frame = core.stage_frame(depth, use_colour && !f.colour_path.empty() ? &colour : nullptr);
    const ImageView<uint16_t> staged(const_cast<uint16_t*>(frame.depth.data), intr.width, intr.height);
    const ImageView<const uint16_t> amp =
        tof && !amplitude.empty() ? ImageView<const uint16_t>(amplitude.data(), intr.width, intr.height)
                                  : ImageView<const uint16_t>();

    double cpu[6];
    cpu[0] = cpu_ms();
    const Clock::time_point t_loop = Clock::now();
    Clock::time_point t0 = t_loop;
    Status s = filters.run(staged, amp, filter_scratch, staged);
    const double t_filter = ms_since(t0);
    cpu[1] = cpu_ms();
    t0 = Clock::now();
    if (s == Status::kOk && i > 0)
      s = raycast_parallel<real_t>(pool, core.volume, intr, tracker.raycast_pose(), model);
    const double t_raycast = ms_since(t0);
    cpu[2] = cpu_ms();
    t0 = Clock::now();
    TrackResult r;
    if (s == Status::kOk) s = build_pyramid<real_t>(frame.depth, PyramidParams(), pyramid);
    if (s == Status::kOk) s = tracker.track<real_t>(pyramid, model, intr, icp_ws, r, rows);
    const double t_icp = ms_since(t0);
    cpu[3] = cpu_ms();
    t0 = Clock::now();
    if (s == Status::kOk && r.push)
      s = integrate_parallel<real_t>(pool, core.volume, intr, core.ray_norms, frame, r.T_world_cam, core.scratch);
    const double t_integrate = ms_since(t0);
    const double t_total = ms_since(t_loop);
    cpu[4] = cpu_ms();
    for (int k = 0; k < 4; ++k) sum.cpu[k] += cpu[k + 1] - cpu[k];
    sum.cpu[4] += cpu[4] - cpu[0];
    if (s != Status::kOk) return fail("frame " + std::to_string(i) + " (" + f.depth_path + "): " + to_string(s));

    trajectory.push_back(io::StampedPose{f.stamp_s, r.T_world_cam});
    sum.filter += t_filter;
    sum.raycast += t_raycast;
    sum.icp += t_icp;
    sum.integrate += t_integrate;
    sum.loop += t_total;
    sum.ok += r.state == TrackState::kOk;
    sum.degraded += r.state == TrackState::kDegraded;
    sum.lost += r.state == TrackState::kLost;
    sum.pushed += r.push;
    std::printf("frame %zu/%zu stamp %.6f: %-8s%s | filter %.2f raycast %.2f icp %.2f integrate %.2f ms", i + 1,
                frame_count, f.stamp_s, r.first ? "first" : to_string(r.state), r.push ? " push" : "     ", t_filter,
                t_raycast, t_icp, t_integrate);
    if (!r.first)
      std::printf(" | inliers %.2f, coverage %.2f, rms %.2f mm, %d dof (weakest %.1e), it %d/%d/%d, start %s%s, "
                  "moved %.1f mm %.2f deg",
                  r.icp.inlier_ratio(), r.icp.coverage(), 1e3f * r.icp.rms_m, r.icp.observable, r.icp.weakest_ratio,
                  r.icp.iterations[2],
                  r.icp.iterations[1], r.icp.iterations[0], r.start == 0 ? "velocity" : "last pose",
                  r.attempts > 1 ? " (2 tried)" : "", 1e3f * r.jump_m, r.jump_deg);
    std::printf("\n");
    std::fflush(stdout);  // progress stays visible when the output goes to a file
  }
  pool.stop();

  const std::string out = args.get("out", "track.txt");
  if (!io::write_tum_trajectory(out, trajectory, err,
                                "edgefuse track " + seq.root + " (sensor " + seq.sensor_name + "), sensor-to-world"))
    return fail(err);
  std::printf("trajectory: %zu poses -> %s\n", trajectory.size(), out.c_str());
  if (args.has("cloud")) {
    io::PointCloud cloud;
    const Status xs = core.extract_cloud(cloud);
    if (!write_cloud(args.get("cloud"), cloud, err)) return fail(err);
    std::printf("cloud: %zu points%s -> %s\n", cloud.size(),
                xs == Status::kOutputTruncated ? " (truncated at the board's point capacity)" : "",
                args.get("cloud").c_str());
  }
  const double n = double(frame_count);
  std::printf("frames=%zu ok=%d degraded=%d lost=%d pushed=%d filter_ms=%.3f raycast_ms=%.3f icp_ms=%.3f "
              "integrate_ms=%.3f loop_ms=%.3f fps=%.1f\n",
              frame_count, sum.ok, sum.degraded, sum.lost, sum.pushed, sum.filter / n, sum.raycast / n, sum.icp / n,
              sum.integrate / n, sum.loop / n, sum.loop > 0 ? 1000.0 * n / sum.loop : 0.0);
  std::printf("cpu (process CPU time, all threads, per frame): filter_ms=%.3f raycast_ms=%.3f icp_ms=%.3f "
              "integrate_ms=%.3f loop_ms=%.3f fps=%.1f\n",
              sum.cpu[0] / n, sum.cpu[1] / n, sum.cpu[2] / n, sum.cpu[3] / n, sum.cpu[4] / n,
              sum.cpu[4] > 0 ? 1000.0 * n / sum.cpu[4] : 0.0);
  return 0;
}

}  // namespace edgefuse::cli
