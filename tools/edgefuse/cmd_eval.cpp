// edgefuse eval: trajectory accuracy, TUM RGB-D benchmark style.
//   eval ate EST GT  ATE RMSE after rigid (Horn/Umeyama, no scale) alignment, as evaluate_ate.py
//   eval rpe EST GT  relative pose error over a fixed frame delta, as evaluate_rpe.py
// EST is a TUM trajectory file; GT a TUM trajectory file or a data-set folder (its groundtruth.txt
// or its per-frame pose files). The last line is machine-readable.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "args.hpp"
#include "commands.hpp"
#include "eval_metrics.hpp"
#include "eval_poses.hpp"  // localisation

namespace edgefuse::cli {
namespace {

const char* kUsage =
    "usage: edgefuse eval ate EST.txt GT [--max-dt 0.02] [--aligned-out FILE] [--sensor NAME]\n"
    "       edgefuse eval rpe EST.txt GT [--delta 1] [--max-dt S] [--sensor NAME]\n"
    "  EST: TUM trajectory (timestamp tx ty tz qx qy qz qw, sensor-to-world; per-frame data sets use\n"
    "  the frame number as timestamp). GT: a TUM trajectory, or a data-set folder of FORMATS.md\n"
    "  (its groundtruth.txt; a rig sensor chosen with --sensor; per-frame pose files).\n"
    "  ate: associates stamps one-to-one within --max-dt seconds (associate.py), aligns EST to GT with\n"
    "       the least-squares rigid transform (no scale, det +1), prints RMSE, mean, median, std, min,\n"
    "       max of the position differences and `ate_rmse_m=X count=N`. --aligned-out writes every EST\n"
    "       pose after the alignment as a TUM trajectory.\n"
    "  rpe: for estimated frames i and i+delta, the error of the relative motion against the GT poses\n"
    "       nearest in time (within --max-dt; default 2 x the median GT interval, as evaluate_rpe.py),\n"
    "       prints `rpe_trans_rmse_m=X rpe_rot_rmse_deg=Y count=N`.\n";

constexpr double kRadToDeg = 180.0 / M_PI;

void print_stats(const char* label, const eval::ErrorStats& s, const char* unit, double scale) {
  std::printf("%s: rmse %.6f %s, mean %.6f, median %.6f, std %.6f, min %.6f, max %.6f %s (%zu pairs)\n", label,
              s.rmse * scale, unit, s.mean * scale, s.median * scale, s.std * scale, s.min * scale, s.max * scale,
              unit, s.count);
}

int fail(const std::string& msg) {
  std::fprintf(stderr, "edgefuse eval: %s\n", msg.c_str());
  return 1;
}

int run_ate(const Args& args, const std::vector<io::StampedPose>& est, const std::vector<io::StampedPose>& gt,
            const std::string& est_path, double max_dt) {
  eval::AteResult r;
  std::string err;
  if (!eval::compute_ate(est, gt, max_dt, r, err)) return fail(est_path + ": " + err);
  std::printf("associated %zu of %zu estimated poses with ground truth (max dt %.4f s, one-to-one as associate.py)\n",
              r.pairs.size(), est.size(), max_dt);
  if (r.pairs.size() < est.size())
    std::printf("warning: %zu estimated poses have no ground truth within %.4f s and are not evaluated\n",
                est.size() - r.pairs.size(), max_dt);
  const Eigen::AngleAxisd aa(r.align.T.R);
  std::printf("alignment GT <- EST (rigid, no scale): rotation %.4f deg about (%.3f, %.3f, %.3f), translation "
              "(%.6f, %.6f, %.6f) m%s\n",
              aa.angle() * kRadToDeg, aa.axis().x(), aa.axis().y(), aa.axis().z(), r.align.T.t.x(), r.align.T.t.y(),
              r.align.T.t.z(), r.align.reflection_avoided ? " [best orthogonal fit was a reflection; det +1 enforced]" : "");
  if (r.align.rank < 2)
    std::printf("note: the associated positions are (nearly) collinear; the rotation about their line is not "
                "determined (the RMSE is still the minimum)\n");
  print_stats("ATE (absolute translational error after alignment)", r.stats, "m", 1.0);
  if (args.has("aligned-out")) {
    std::vector<io::StampedPose> aligned(est.size());
    for (std::size_t i = 0; i < est.size(); ++i)
      aligned[i] = {est[i].stamp_s, (r.align.T * eval::RigidD::from_pose(est[i].T)).to_pose()};
    const std::string out = args.get("aligned-out");
    if (!io::write_tum_trajectory(out, aligned, err, "edgefuse eval ate: " + est_path + " aligned to the ground truth"))
      return fail(err);
    std::printf("aligned trajectory (%zu poses) -> %s\n", aligned.size(), out.c_str());
  }
  std::printf("ate_rmse_m=%.6f count=%zu\n", r.stats.rmse, r.stats.count);
  return 0;
}

int run_rpe(const std::vector<io::StampedPose>& est, const std::vector<io::StampedPose>& gt,
            const std::string& est_path, const eval::RpeOptions& opt) {
  eval::RpeResult r;
  std::string err;
  if (!eval::compute_rpe(est, gt, opt, r, err)) return fail(est_path + ": " + err);
  std::printf("frame pairs (i, i+%d): %zu of %zu have ground truth within %.4f s at both ends%s\n", opt.delta,
              r.pairs.size(), r.candidates, r.gt_max_dt_s,
              opt.max_dt_s < 0 ? " (2 x median GT interval, as evaluate_rpe.py)" : "");
  print_stats("RPE translational", r.trans_m, "m", 1.0);
  print_stats("RPE rotational", r.rot_deg, "deg", 1.0);
  std::printf("rpe_trans_rmse_m=%.6f rpe_rot_rmse_deg=%.6f count=%zu\n", r.trans_m.rmse, r.rot_deg.rmse,
              r.trans_m.count);
  return 0;
}

}  // namespace

int cmd_eval(int argc, char** argv) {
  if (argc >= 1 && (!std::strcmp(argv[0], "--help") || !std::strcmp(argv[0], "-h"))) {
    std::printf("%s%s", kUsage,
                "usage: edgefuse eval poses EST.txt TRUE.txt [--models DIR]\n"
                "       edgefuse eval segments PRED.pcd TRUTH.pcd [--parts]\n"
                "  (edgefuse eval poses --help, edgefuse eval segments --help: what they compute)\n");
    return 0;
  }
  // localisation: object poses and segments
  if (argc >= 1 && !std::strcmp(argv[0], "poses")) return cmd_eval_poses(argc - 1, argv + 1);
  if (argc >= 1 && !std::strcmp(argv[0], "segments")) return cmd_eval_segments(argc - 1, argv + 1);
  if (argc < 1 || (std::strcmp(argv[0], "ate") && std::strcmp(argv[0], "rpe"))) {
    std::fprintf(stderr, "edgefuse eval: expected 'ate', 'rpe', 'poses' or 'segments'%s%s\n%s", argc < 1 ? "" : ", got ",
                 argc < 1 ? "" : argv[0], kUsage);
    return 2;
  }
  const bool ate = !std::strcmp(argv[0], "ate");
  Args args;
  std::string err;
  const std::vector<std::string> options =
      ate ? std::vector<std::string>{"max-dt", "aligned-out", "sensor"} : std::vector<std::string>{"delta", "max-dt", "sensor"};
  if (!args.parse(argc - 1, argv + 1, options, {}, err) || args.positional().size() != 2) {
    std::fprintf(stderr, "edgefuse eval %s: %s\n%s", argv[0], err.empty() ? "expected EST and GT" : err.c_str(), kUsage);
    return 2;
  }
  double max_dt = 0.02;  // parsed as double: stamps are ~1e9 s with microseconds
  int delta = 1;
  if (!args.get_int("delta", 1, 1 << 30, delta, err)) {
    std::fprintf(stderr, "edgefuse eval %s: %s\n", argv[0], err.c_str());
    return 2;
  }
  if (args.has("max-dt")) {
    const std::string s = args.get("max-dt");
    char* end = nullptr;
    max_dt = std::strtod(s.c_str(), &end);
    if (s.empty() || *end != '\0' || !std::isfinite(max_dt) || !(max_dt > 0)) {
      std::fprintf(stderr, "edgefuse eval %s: --max-dt must be a positive number of seconds, got '%s'\n", argv[0],
                   s.c_str());
      return 2;
    }
  }
  const std::string est_path = args.positional()[0], gt_path = args.positional()[1];
  std::vector<io::StampedPose> est, gt;
  std::string est_what, gt_what;
  if (!eval::load_trajectory(est_path, "", est, est_what, err)) return fail(err);
  if (!eval::load_trajectory(gt_path, args.get("sensor"), gt, gt_what, err)) return fail(err);
  std::printf("edgefuse eval %s: estimate %s (%zu poses, stamps %.6f..%.6f)\n", argv[0], est_what.c_str(), est.size(),
              est.front().stamp_s, est.back().stamp_s);
  std::printf("ground truth %s (%zu poses, stamps %.6f..%.6f)\n", gt_what.c_str(), gt.size(), gt.front().stamp_s,
              gt.back().stamp_s);
  if (ate) return run_ate(args, est, gt, est_path, max_dt);
  eval::RpeOptions opt;
  opt.delta = delta;
  if (args.has("max-dt")) opt.max_dt_s = max_dt;
  return run_rpe(est, gt, est_path, opt);
}

}  // namespace edgefuse::cli
