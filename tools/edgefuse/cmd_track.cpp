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
#include "edgefuse/io/dataset.hpp"
#include "edgefuse/io/trajectory.hpp"
#include "edgefuse/pipeline/mapper.hpp"

namespace edgefuse::cli {
namespace {

using Clock = std::chrono::steady_clock;

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

// The end of each phase of a mapping step, in wall and process CPU time.
class PhaseClock : public StepObserver {
 public:
  void begin() {
    wall_[0] = Clock::now();
    cpu_[0] = cpu_ms();
    for (int k = 1; k < 5; ++k) {
      wall_[k] = wall_[0];
      cpu_[k] = cpu_[0];
    }
  }
  void phase_done(MapPhase phase) override {
    const int k = int(phase) + 1;
    wall_[k] = Clock::now();
    cpu_[k] = cpu_ms();
    for (int j = k + 1; j < 5; ++j) {  // phases that do not run take no time
      wall_[j] = wall_[k];
      cpu_[j] = cpu_[k];
    }
  }
  //! Wall time of phase k (filter, raycast, track, integrate) in ms; k = 4: the whole step.
  double wall_ms(int k) const {
    const Clock::time_point a = k == 4 ? wall_[0] : wall_[k], b = k == 4 ? wall_[4] : wall_[k + 1];
    return std::chrono::duration<double, std::milli>(b - a).count();
  }
  double cpu(int k) const { return k == 4 ? cpu_[4] - cpu_[0] : cpu_[k + 1] - cpu_[k]; }

 private:
  Clock::time_point wall_[5];
  double cpu_[5] = {};
};

int fail(const std::string& msg) {
  std::fprintf(stderr, "edgefuse track: %s\n", msg.c_str());
  return 1;
}

void print_frame(std::size_t i, std::size_t n, double stamp_s, const TrackResult& r, const PhaseClock& clock) {
  std::printf("frame %zu/%zu stamp %.6f: %-8s%s | filter %.2f raycast %.2f icp %.2f integrate %.2f ms", i + 1, n,
              stamp_s, r.first ? "first" : to_string(r.state), r.push ? " push" : "     ", clock.wall_ms(0),
              clock.wall_ms(1), clock.wall_ms(2), clock.wall_ms(3));
  if (!r.first)
    std::printf(" | inliers %.2f, coverage %.2f, rms %.2f mm, %d dof (weakest %.1e), it %d/%d/%d, start %s%s, "
                "moved %.1f mm %.2f deg",
                r.icp.inlier_ratio(), r.icp.coverage(), 1e3f * r.icp.rms_m, r.icp.observable, r.icp.weakest_ratio,
                r.icp.iterations[2], r.icp.iterations[1], r.icp.iterations[0],
                r.start == 0 ? "velocity" : "last pose", r.attempts > 1 ? " (2 tried)" : "", 1e3f * r.jump_m,
                r.jump_deg);
  std::printf("\n");
  std::fflush(stdout);  // progress stays visible when the output goes to a file
}

void print_totals(std::size_t frame_count, const Totals& sum) {
  const double n = double(frame_count);
  std::printf("frames=%zu ok=%d degraded=%d lost=%d pushed=%d filter_ms=%.3f raycast_ms=%.3f icp_ms=%.3f "
              "integrate_ms=%.3f loop_ms=%.3f fps=%.1f\n",
              frame_count, sum.ok, sum.degraded, sum.lost, sum.pushed, sum.filter / n, sum.raycast / n, sum.icp / n,
              sum.integrate / n, sum.loop / n, sum.loop > 0 ? 1000.0 * n / sum.loop : 0.0);
  std::printf("cpu (process CPU time, all threads, per frame): filter_ms=%.3f raycast_ms=%.3f icp_ms=%.3f "
              "integrate_ms=%.3f loop_ms=%.3f fps=%.1f\n",
              sum.cpu[0] / n, sum.cpu[1] / n, sum.cpu[2] / n, sum.cpu[3] / n, sum.cpu[4] / n,
              sum.cpu[4] > 0 ? 1000.0 * n / sum.cpu[4] : 0.0);
}

void add_frame(const TrackResult& r, const PhaseClock& clock, Totals& sum) {
  sum.filter += clock.wall_ms(0);
  sum.raycast += clock.wall_ms(1);
  sum.icp += clock.wall_ms(2);
  sum.integrate += clock.wall_ms(3);
  sum.loop += clock.wall_ms(4);
  for (int k = 0; k < 5; ++k) sum.cpu[k] += clock.cpu(k);
  sum.ok += r.state == TrackState::kOk;
  sum.degraded += r.state == TrackState::kDegraded;
  sum.lost += r.state == TrackState::kLost;
  sum.pushed += r.push;
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

  // Pre-filters and noise model by the sensor's kind: ToF when the sequence has amplitude images.
  const bool tof = !seq.frames[0].amplitude_path.empty();
  CoreSetup core;
  CameraSlot cam;
  if (!core.init(board, intr, err) ||
      !core.bind_camera(cam, 0, intr, tof ? DepthSensorKind::kTimeOfFlight : DepthSensorKind::kStructuredLight,
                        true, false, err))
    return fail(seq.root + ": " + err);

  const Pose first_pose = seq.frames[0].has_pose ? seq.frames[0].T_world_cam : Pose::identity();
  std::vector<uint16_t> depth, amplitude;
  std::vector<Rgb8> colour;
  if (!io::load_depth(seq.frames[0], intr, depth, err)) return fail(err);
  if (!centre_on_view(intr, depth, first_pose, settings, seq.frames[0].depth_path, err)) return fail(err);
  if (!core.make_volume(settings, err)) return fail(err);

  PoolRunners threads;
  threads.start(settings.threads);
  MapperParams mp;
  mp.poses = PoseMode::kTracked;
  mp.tracker.push.every_frame = args.has("push-every-frame");
  Mapper mapper;
  if (mapper.init(core.volume, threads.runners(), core.spare_image(intr.width, intr.height),
                  core.centre_scratch(intr), mp) != Status::kOk)
    return fail("bad tracker parameters");
  mapper.new_map_in_place();  // centred on the raw first view above

  const Vec3f& o = core.volume.origin_m();
  std::printf("edgefuse track: %s (%s, sensor %s), %zu of %zu frames, %dx%d fx %.1f fy %.1f, %s filters\n",
              seq.root.c_str(), io::to_string(seq.layout), seq.sensor_name.c_str(), frame_count, seq.frames.size(),
              intr.width, intr.height, intr.fx, intr.fy, tof ? "time-of-flight" : "structured-light");
  std::printf("volume: %d^3 voxels of %.4f m, origin %.4f,%.4f,%.4f, trunc %.4f m, %s kernels, %d threads; "
              "first pose from %s; push %s\n",
              settings.dim, settings.voxel_m, o.x(), o.y(), o.z(), settings.trunc_m,
              kFixedPointBuild ? "fixed-point" : "float", settings.threads,
              seq.frames[0].has_pose ? "ground truth" : "identity",
              mp.tracker.push.every_frame ? "every frame" : "after 1 cm / 1 deg");

  const bool use_colour = seq.colour_registered && core.volume.has_colour();
  std::vector<io::StampedPose> trajectory;
  trajectory.reserve(frame_count);
  Totals sum;
  PhaseClock clock;
  for (std::size_t i = 0; i < frame_count; ++i) {
    const io::FrameRef& f = seq.frames[i];
    if (i > 0 && !io::load_depth(f, intr, depth, err)) return fail(err);
    const bool with_colour = use_colour && !f.colour_path.empty();
    if (with_colour && !io::load_colour(f, intr, colour, err)) return fail(err);
    if (tof && !f.amplitude_path.empty() && !io::load_amplitude(f, intr, amplitude, err)) return fail(err);
    const DepthFrame staged = core.stage_frame(depth, with_colour ? &colour : nullptr);
    SensorFrame frame;
    frame.depth = staged.depth;
    frame.colour = staged.colour;
    if (tof && !amplitude.empty()) frame.amplitude = ImageView<const uint16_t>(amplitude.data(), intr.width, intr.height);

    clock.begin();
    ReferenceStep step;
    const Status s = mapper.map_reference(cam, frame, nullptr, first_pose, step, &clock);
    if (s != Status::kOk) return fail("frame " + std::to_string(i) + " (" + f.depth_path + "): " + to_string(s));
    trajectory.push_back(io::StampedPose{f.stamp_s, step.T_world_cam});
    add_frame(step.track, clock, sum);
    print_frame(i, frame_count, f.stamp_s, step.track, clock);
  }
  threads.pool.stop();

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
  print_totals(frame_count, sum);
  return 0;
}

}  // namespace edgefuse::cli
