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

#include "failure.hpp"
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
    "  voxels of truncation when only --voxel is given); volume from the board's [tsdf] too, centred on\n"
    "  what the first frame sees; --out track.txt. Without --voxel and --volume, when that space holds\n"
    "  less than 90 % of the first frame's points, it grows to the board's capacity per axis, then the\n"
    "  voxel grows (4 mm, 5 mm, 1 cm, 2 cm) until it does, and a line says so; an explicit space is\n"
    "  kept (a warning when it holds less than half).\n"
    "  Frames are pushed when the sensor moved 1 cm or 1 degree since the last push\n"
    "  (--push-every-frame: always), never while tracking is lost.\n";

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

//! When more than half the frames after the first were lost or degraded, says what likely happened
//! and what to try: the counts alone left a new user guessing.
//! \param frame_count frames tracked  \param sum their states  \param settings the space they were fused in
void print_tracking_advice(std::size_t frame_count, const Totals& sum, const FuseSettings& settings) {
  const int tracked = int(frame_count) - 1;  // the first frame is placed, not tracked
  if (tracked < 1 || 2 * (sum.lost + sum.degraded) <= tracked) return;
  std::printf("track: %d of %d frames were not tracked well (lost %d, degraded %d): the model the frames are "
              "aligned to is likely too small or too sparse (the space is %d^3 x %.4f m = %.2f m; lost frames "
              "are not fused), or the sensor moved too fast; try --voxel 0.01 for a room-sized scene, "
              "--push-every-frame, or a recording with smaller steps between frames\n",
              sum.lost + sum.degraded, tracked, sum.lost, sum.degraded, settings.dim, double(settings.voxel_m),
              double(float(settings.dim) * settings.voxel_m));
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


// What the command line asks for.
struct TrackOptions {
  Args args;
  FuseSettings settings;
  int frames_max = 0;
};

bool parse_options(int argc, char** argv, TrackOptions& o, Failure& f) {
  std::string err;
  if (!o.args.parse(argc, argv, {"sensor", "frames", "out", "cloud", "voxel", "trunc", "volume", "threads"},
                    {"push-every-frame"}, err) ||
      o.args.positional().size() != 1) {
    f.usage = true;
    return fail(f, err.empty() ? "expected one DATASET" : err, 2);
  }
  const BoardCapacities& board = build_board();
  if (!board_fuse_settings(o.settings, err)) return fail(f, err);
  // no --origin: centred on the first view
  if (!apply_fuse_options(o.args, o.settings, o.frames_max, err)) return fail(f, err, 2);
  if (board.sensors_max < 2)
    return fail(f, "board " + std::string(board.name) + " has no spare frame buffer for filtering");
  return true;
}

// The sequence, the core it is fused in and what the loop produces.
struct TrackRun {
  io::DepthSequence seq;
  std::size_t frame_count = 0;
  bool tof = false;  // pre-filters and noise model by the sensor's kind: ToF with amplitude images
  Pose first_pose;   // the first frame's ground truth, else the identity
  CoreSetup core;
  CameraSlot cam;
  std::vector<uint16_t> depth, amplitude;  // the frame being tracked (the first one once the volume is placed)
  std::vector<Rgb8> colour;
  std::vector<io::StampedPose> trajectory;
  Totals sum;
};

bool open_sequence(const TrackOptions& o, TrackRun& run, Failure& f) {
  std::string err;
  if (!io::open_depth_sequence(o.args.positional()[0], o.args.get("sensor"), run.seq, err)) return fail(f, err);
  run.frame_count = std::min<std::size_t>(run.seq.frames.size(), std::size_t(o.frames_max));
  if (run.frame_count == 0) return fail(f, run.seq.root + " has no frames");
  return true;
}

// The core's buffers and the camera, then the volume centred on what the first frame sees.
bool set_up_core(TrackOptions& o, TrackRun& run, Failure& f) {
  const io::DepthSequence& seq = run.seq;
  const PinholeIntrinsics& intr = seq.intr;
  std::string err;
  // Pre-filters and noise model by the sensor's kind: ToF when the sequence has amplitude images.
  run.tof = !seq.frames[0].amplitude_path.empty();
  if (!run.core.init(build_board(), intr, err) ||
      !run.core.bind_camera(run.cam, 0, intr,
                            run.tof ? DepthSensorKind::kTimeOfFlight : DepthSensorKind::kStructuredLight, true, false,
                            err))
    return fail(f, seq.root + ": " + err);
  run.first_pose = seq.frames[0].has_pose ? seq.frames[0].T_world_cam : Pose::identity();
  if (!io::load_depth(seq.frames[0], intr, run.depth, err)) return fail(f, err);
  if (!size_space_to_view("track", intr, run.depth, run.first_pose, o.settings, seq.frames[0].depth_path, err))
    return fail(f, err);
  if (!run.core.make_volume(o.settings, err)) return fail(f, err);
  return true;
}

void print_header(const TrackOptions& o, const TrackRun& run, const MapperParams& mp) {
  const io::DepthSequence& seq = run.seq;
  const PinholeIntrinsics& intr = seq.intr;
  const FuseSettings& settings = o.settings;
  const Vec3f& org = run.core.volume.origin_m();
  std::printf("edgefuse track: %s (%s, sensor %s), %zu of %zu frames, %dx%d fx %.1f fy %.1f, %s filters\n",
              seq.root.c_str(), io::to_string(seq.layout), seq.sensor_name.c_str(), run.frame_count,
              seq.frames.size(), intr.width, intr.height, intr.fx, intr.fy,
              run.tof ? "time-of-flight" : "structured-light");
  std::printf("volume: %d^3 voxels of %.4f m, origin %.4f,%.4f,%.4f, trunc %.4f m, %s kernels, %d threads; "
              "first pose from %s; push %s\n",
              settings.dim, settings.voxel_m, org.x(), org.y(), org.z(), settings.trunc_m,
              kFixedPointBuild ? "fixed-point" : "float", settings.threads,
              seq.frames[0].has_pose ? "ground truth" : "identity",
              mp.tracker.push.every_frame ? "every frame" : "after 1 cm / 1 deg");
}

// Frame i: loaded (frame 0 already is), tracked and pushed by the mapping step, timed per phase.
bool track_frame(TrackRun& run, std::size_t i, Mapper& mapper, PhaseClock& clock, Failure& f) {
  const io::DepthSequence& seq = run.seq;
  const PinholeIntrinsics& intr = seq.intr;
  const io::FrameRef& fr = seq.frames[i];
  std::string err;
  if (i > 0 && !io::load_depth(fr, intr, run.depth, err)) return fail(f, err);
  const bool with_colour = seq.colour_registered && run.core.volume.has_colour() && !fr.colour_path.empty();
  if (with_colour && !io::load_colour(fr, intr, run.colour, err)) return fail(f, err);
  if (run.tof && !fr.amplitude_path.empty() && !io::load_amplitude(fr, intr, run.amplitude, err)) return fail(f, err);
  const DepthFrame staged = run.core.stage_frame(run.depth, with_colour ? &run.colour : nullptr);
  SensorFrame frame;
  frame.depth = staged.depth;
  frame.colour = staged.colour;
  if (run.tof && !run.amplitude.empty())
    frame.amplitude = ImageView<const uint16_t>(run.amplitude.data(), intr.width, intr.height);

  clock.begin();
  ReferenceStep step;
  const Status s = mapper.map_reference(run.cam, frame, nullptr, run.first_pose, step, &clock);
  if (s != Status::kOk) return fail(f, "frame " + std::to_string(i) + " (" + fr.depth_path + "): " + to_string(s));
  run.trajectory.push_back(io::StampedPose{fr.stamp_s, step.T_world_cam});
  add_frame(step.track, clock, run.sum);
  print_frame(i, run.frame_count, fr.stamp_s, step.track, clock);
  return true;
}

// The loop: every frame through the pipeline's mapping step at tracked poses.
bool track_frames(const TrackOptions& o, TrackRun& run, Failure& f) {
  const PinholeIntrinsics& intr = run.seq.intr;
  PoolRunners threads;
  threads.start(o.settings.threads);
  MapperParams mp;
  mp.poses = PoseMode::kTracked;
  mp.tracker.push.every_frame = o.args.has("push-every-frame");
  Mapper mapper;
  if (mapper.init(run.core.volume, threads.runners(), run.core.spare_image(intr.width, intr.height),
                  run.core.centre_scratch(intr), mp) != Status::kOk)
    return fail(f, "bad tracker parameters");
  mapper.new_map_in_place();  // centred on the raw first view above
  print_header(o, run, mp);
  run.trajectory.reserve(run.frame_count);
  PhaseClock clock;
  for (std::size_t i = 0; i < run.frame_count; ++i)
    if (!track_frame(run, i, mapper, clock, f)) return false;
  threads.pool.stop();
  return true;
}

// The trajectory (and the cloud), then the totals.
bool write_outputs(const TrackOptions& o, const TrackRun& run, Failure& f) {
  const io::DepthSequence& seq = run.seq;
  std::string err;
  const std::string out = o.args.get("out", "track.txt");
  if (!io::write_tum_trajectory(out, run.trajectory, err,
                                "edgefuse track " + seq.root + " (sensor " + seq.sensor_name + "), sensor-to-world"))
    return fail(f, err);
  std::printf("trajectory: %zu poses -> %s\n", run.trajectory.size(), out.c_str());
  if (o.args.has("cloud")) {
    io::PointCloud cloud;
    const Status xs = run.core.extract_cloud(cloud);
    if (!write_cloud(o.args.get("cloud"), cloud, err)) return fail(f, err);
    std::printf("cloud: %zu points%s -> %s\n", cloud.size(),
                xs == Status::kOutputTruncated ? " (truncated at the board's point capacity)" : "",
                o.args.get("cloud").c_str());
  }
  std::printf("%s\n", run.core.space_usage().c_str());
  print_totals(run.frame_count, run.sum);
  print_tracking_advice(run.frame_count, run.sum, o.settings);
  return true;
}

}  // namespace

int cmd_track(int argc, char** argv) {
  if (help_asked(argc, argv, kUsage)) return 0;
  TrackOptions o;
  Failure f;
  TrackRun run;
  if (!parse_options(argc, argv, o, f) || !open_sequence(o, run, f) || !set_up_core(o, run, f) ||
      !track_frames(o, run, f) || !write_outputs(o, run, f))
    return report("edgefuse track", f, kUsage);
  return 0;
}

}  // namespace edgefuse::cli
