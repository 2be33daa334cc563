// edgefuse handeye: the camera's mounting on a robot's flange (hand-eye, T_flange_<sensor>) without
// a calibration target. The camera's motion comes from the data through the pipeline's Mapper in
// its robot+icp mode: the stations are mapped into one space placed in the robot's base frame, each
// station's prior being the robot's flange pose times the hand-measured mounting; the first is
// integrated at its prior, every later one aligned by ICP against the space raycast at its prior and
// integrated where the ICP put it; once the space holds them all, each station is aligned again
// against it. AX = XB over all station pairs (fusion/hand_eye.hpp) then gives the mounting. Never reads ground truth: the sequence's recorded poses are dropped on opening.
#include <algorithm>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "args.hpp"
#include "commands.hpp"
#include "core_setup.hpp"
#include "edgefuse/fusion/hand_eye.hpp"
#include "edgefuse/io/trajectory.hpp"
#include "failure.hpp"
#include "fuse_options.hpp"
#include "rig_calibration.hpp"
#include "rig_fusion.hpp"

namespace edgefuse::cli {
namespace {

const char* kUsage =
    "usage: edgefuse handeye DATASET [--sensor NAME] --robot FILE [--guess tx,ty,tz,rx,ry,rz] [--out FILE]\n"
    "                        [--voxel M] [--frames N]\n"
    "  Hand-eye calibration without a target: T_flange_<sensor>, the pose of the camera in the robot\n"
    "  flange's frame, from the camera's depth frames taken at robot stations. FILE: the flange poses\n"
    "  T_base_flange (TUM format: timestamp tx ty tz qx qy qz qw, flange-to-base) at the frames' stamps.\n"
    "  The stations are mapped into one space in the robot's base frame through the pipeline (robot+icp):\n"
    "  each station's prior is its flange pose times the guess; the first is integrated at its prior,\n"
    "  every later one aligned by ICP against the space raycast at its prior, then integrated; then every\n"
    "  station is aligned again against the whole space. AX = XB over all station pairs (Park & Martin,\n"
    "  refined by Gauss-Newton) gives the mounting, printed as 'T_flange_<sensor> tx ty tz qx qy qz qw'\n"
    "  with per-station residuals and its 1-sigma.\n"
    "  --guess: the hand-measured mounting (metres, degrees as a rotation vector); required: stations\n"
    "  tens of degrees apart are beyond the ICP's reach without a prior (finding the mounting without\n"
    "  one, by global registration, is future work). --out FILE appends the T_flange line. --frames N:\n"
    "  the first N frames (at most 32 stations). Ground truth (groundtruth.txt, robot/truth.txt) is\n"
    "  never read. Exit 3 when the motion does not determine the mounting (the reason is printed).\n";

// What the command line asks for.
struct HandEyeOptions {
  Args args;
  std::string folder;
  FuseSettings settings;
  int frames_max = 0;
  Pose guess;
};

bool parse_options(int argc, char** argv, HandEyeOptions& o, Failure& f) {
  std::string err;
  f.usage = true;
  if (!o.args.parse(argc, argv, {"sensor", "robot", "guess", "out", "voxel", "frames"}, {}, err) ||
      o.args.positional().size() != 1)
    return fail(f, err.empty() ? "expected one DATASET" : err, 2);
  if (!o.args.has("robot")) return fail(f, "--robot FILE (the flange poses at the frames' stamps) is required", 2);
  f.usage = false;
  if (!o.args.has("guess"))
    return fail(f,
                "--guess tx,ty,tz,rx,ry,rz is required: a hand-measured mounting of the camera on the flange "
                "(a few mm and degrees off is enough); the stations are too far apart for ICP without it, and "
                "finding the mounting without a guess (global registration) is future work",
                2);
  if (!parse_guess(o.args.get("guess"), o.guess, err)) return fail(f, err, 2);
  if (!board_fuse_settings(o.settings, err)) return fail(f, err);
  if (!apply_fuse_options(o.args, o.settings, o.frames_max, err)) return fail(f, err, 2);
  o.folder = o.args.positional()[0];
  return true;
}

// One robot station: a frame of the camera, its flange pose, and what mapping made of it.
struct Station {
  std::size_t frame = 0;  // index in the sequence
  Pose T_base_flange;
  Pose prior;             // T_base_flange * guess
  ReferenceStep step;     // mapped: corrected from the prior and integrated
  TrackResult final;      // aligned again against the map of every station, from the mapped pose
};

struct HandEyeRun {
  RigCamera cam;
  CoreSetup core;
  Mapper mapper;
  std::vector<Station> stations;
  int skipped_no_robot = 0;  // frames without a flange pose within 0.02 s
};

// The camera's frames (recorded poses dropped: the method must not see them) and the flange pose of
// each frame's stamp.
bool open_stations(const HandEyeOptions& o, HandEyeRun& run, Failure& f) {
  std::string err;
  io::DepthSequence& seq = run.cam.seq;
  if (!io::open_depth_sequence(o.folder, o.args.get("sensor"), seq, err)) return fail(f, err);
  for (io::FrameRef& fr : seq.frames) fr.has_pose = false;
  std::vector<io::StampedPose> flange;
  if (!io::read_tum_trajectory(o.args.get("robot"), flange, err)) return fail(f, err);
  const std::size_t n = std::min<std::size_t>(seq.frames.size(), std::size_t(o.frames_max));
  for (std::size_t i = 0; i < n; ++i) {
    const io::StampedPose* p = io::find_nearest(flange, seq.frames[i].stamp_s, 0.02);
    if (p == nullptr) {
      ++run.skipped_no_robot;
      continue;
    }
    if (int(run.stations.size()) == kHandEyeStationsMax) break;
    Station s;
    s.frame = i;
    s.T_base_flange = p->T;
    s.prior = p->T * o.guess;
    run.stations.push_back(s);
  }
  if (run.stations.empty())
    return fail(f, o.args.get("robot") + ": no flange pose within 0.02 s of a frame of " + seq.root);
  return true;
}

// The core's buffers, the camera in slot 0 and the space centred on the first station's view at its prior.
bool set_up_core(HandEyeOptions& o, HandEyeRun& run, Failure& f) {
  std::string err;
  RigCamera& c = run.cam;
  if (!run.core.init(build_board(), c.seq.intr, err)) return fail(f, c.seq.root + ": " + err);
  c.slot = 0;
  if (!c.bind(run.core, true, err)) return fail(f, err);
  // Masks and jump edges, no bilateral smoothing: it moves the depth edges that pin the lateral
  // directions (as for the rigid-pair calibration; handeye_rig_a over six guesses: mean error
  // 0.18 mm without it, 0.33 mm with it).
  c.cam.filters.bilateral_enabled = false;
  const Station& first = run.stations.front();
  if (!io::load_depth(c.seq.frames[first.frame], c.seq.intr, c.load_depth, err)) return fail(f, err);
  if (!centre_on_view(c.seq.intr, c.load_depth, first.prior, o.settings, c.seq.frames[first.frame].depth_path, err))
    return fail(f, err);
  if (!run.core.make_volume(o.settings, err)) return fail(f, err);
  return true;
}

// Every station through the Mapper at robot+icp: the prior corrected by ICP, then integrated.
bool map_stations(const HandEyeOptions& o, HandEyeRun& run, Failure& f) {
  RigCamera& c = run.cam;
  MapperParams mp;
  mp.poses = PoseMode::kPrior;
  mp.tracker.push.every_frame = true;  // every station adds its view to the space
  const PinholeIntrinsics& intr = c.seq.intr;
  if (run.mapper.init(run.core.volume, KernelRunners(), run.core.spare_image(intr.width, intr.height),
                      run.core.centre_scratch(intr), mp) != Status::kOk)
    return fail(f, "bad tracker parameters");
  run.mapper.new_map_in_place();  // centred on the first station's view above
  std::string err;
  for (Station& s : run.stations) {
    SensorFrame frame;
    if (!c.load(s.frame, false, frame, err)) return fail(f, err);
    if (run.mapper.map_reference(c.cam, frame, &s.prior, s.prior, s.step) != Status::kOk)
      return fail(f, c.seq.frames[s.frame].depth_path + ": mapping failed");
  }
  std::printf("edgefuse handeye: %s (sensor %s), %zu stations, robot %s, guess %s\n", c.seq.root.c_str(),
              c.seq.sensor_name.c_str(), run.stations.size(), o.args.get("robot").c_str(),
              pose_line(o.guess).c_str());
  std::printf("space: %d^3 voxels of %.4f m, trunc %.4f m, %s kernels; robot+icp: prior = flange pose x guess\n",
              o.settings.dim, o.settings.voxel_m, o.settings.trunc_m, kFixedPointBuild ? "fixed-point" : "float");
  if (run.skipped_no_robot > 0) std::printf("%d frames without a flange pose skipped\n", run.skipped_no_robot);
  return true;
}

// Once the space holds every station, each (the first included) is aligned again against it from
// its mapped pose: the first station no longer anchors the others on its one view (measured on
// handeye_rig_a: 0.32 -> 0.29 mm with exact flange poses, 0.58 -> 0.44 mm with noisy ones).
bool realign_stations(HandEyeRun& run, Failure& f) {
  RigCamera& c = run.cam;
  std::string err;
  for (Station& s : run.stations) {
    if (!s.step.integrated) continue;  // lost while mapping: robot and data disagree there
    SensorFrame frame;
    if (!c.load(s.frame, false, frame, err)) return fail(f, err);
    if (run.mapper.align_reference(c.cam, frame, s.step.T_world_cam, s.final) != Status::kOk)
      return fail(f, c.seq.frames[s.frame].depth_path + ": alignment failed");
  }
  return true;
}

// A station's camera pose is measured when the final alignment constrained all six directions and
// fit (ok); a degraded one kept the prior in some direction.
bool measured(const Station& s) { return s.step.integrated && s.final.state == TrackState::kOk; }

bool solve(const HandEyeRun& run, HandEyeResult& r, std::vector<int>& used, Failure& f) {
  std::vector<Pose> a, c;
  for (std::size_t i = 0; i < run.stations.size(); ++i) {
    const Station& s = run.stations[i];
    if (!measured(s)) continue;
    used.push_back(int(i));
    a.push_back(s.T_base_flange);
    c.push_back(s.final.T_world_cam);
  }
  if (a.size() < 3 && run.stations.size() >= 3) {  // the data refused the guess, not the motion
    r = HandEyeResult{};
    std::snprintf(r.reason, sizeof(r.reason),
                  "only %zu of %zu stations aligned in all six directions (is the guess within a few cm and degrees?)",
                  a.size(), run.stations.size());
    return true;
  }
  if (solve_hand_eye(a.data(), c.data(), int(a.size()), HandEyeParams(), r) != Status::kOk)
    return fail(f, "hand-eye solve refused its input");
  return true;
}

void print_station(const HandEyeRun& run, std::size_t i, const HandEyeResult& r, int k) {
  const Station& s = run.stations[i];
  const TrackResult& t = s.step.track;
  std::printf("station %2zu stamp %.6f: %-8s", i, run.cam.seq.frames[s.frame].stamp_s,
              t.first ? "first" : to_string(t.state));
  if (t.first)
    std::printf(" %-31s", "placed the space at its prior");
  else
    std::printf(" correction %6.2f mm %6.3f deg", 1e3f * t.jump_m, t.jump_deg);
  if (s.step.integrated)
    std::printf(" | final %-8s %5.2f mm %5.3f deg, rms %.2f mm, inliers %.2f", to_string(s.final.state),
                1e3f * s.final.jump_m, s.final.jump_deg, 1e3f * s.final.icp.rms_m, s.final.icp.inlier_ratio());
  if (k >= 0 && r.solved)
    std::printf(" | residual %.3f mm %.4f deg", 1e3f * r.station_residual_m[k], r.station_residual_deg[k]);
  else if (k < 0)
    std::printf(" | not used (not aligned in all six directions)");
  std::printf("\n");
}

bool report_result(const HandEyeOptions& o, const HandEyeRun& run, const HandEyeResult& r, const std::vector<int>& used,
                   Failure& f) {
  for (std::size_t i = 0; i < run.stations.size(); ++i) {
    const auto it = std::find(used.begin(), used.end(), int(i));
    print_station(run, i, r, it == used.end() ? -1 : int(it - used.begin()));
  }
  if (!r.solved) return fail(f, std::string("refused: ") + r.reason, 3);
  const float deg = 180.0f / 3.14159265f;
  const std::string line = "T_flange_" + run.cam.seq.sensor_name + " " + pose_line(r.T_flange_cam);
  std::printf("%s\n", line.c_str());
  std::printf("1-sigma (flange frame): rot %.4f %.4f %.4f deg, trans %.3f %.3f %.3f mm; %d stations, %d pairs, "
              "pair rms %.3f mm %.4f deg, %d iterations\n",
              deg * r.sigma(0), deg * r.sigma(1), deg * r.sigma(2), 1e3f * r.sigma(3), 1e3f * r.sigma(4),
              1e3f * r.sigma(5), r.stations, r.pairs, 1e3f * r.rms_translation_m, r.rms_rotation_deg, r.iterations);
  const Pose d = r.T_flange_cam.inverse() * o.guess;
  std::printf("the guess was %.2f mm %.3f deg from it\n", 1e3f * (o.guess.t - r.T_flange_cam.t).norm(),
              deg * d.angle_rad());
  if (!o.args.has("out")) return true;
  std::ofstream out(o.args.get("out"), std::ios::app);
  out << line << "\n";
  if (!out) return fail(f, "cannot write " + o.args.get("out"));
  std::printf("written to %s\n", o.args.get("out").c_str());
  return true;
}

}  // namespace

int cmd_handeye(int argc, char** argv) {
  if (help_asked(argc, argv, kUsage)) return 0;
  HandEyeOptions o;
  Failure f;
  HandEyeRun run;
  HandEyeResult r;
  std::vector<int> used;
  if (!parse_options(argc, argv, o, f) || !open_stations(o, run, f) || !set_up_core(o, run, f) ||
      !map_stations(o, run, f) || !realign_stations(run, f) || !solve(run, r, used, f) || !report_result(o, run, r, used, f))
    return report("edgefuse handeye", f, kUsage);
  return 0;
}

}  // namespace edgefuse::cli
