// edgefuse eval poses EST.txt TRUE.txt --models DIR: object pose accuracy (translation / rotation
// error, recall at 5 mm/5 deg and 10 mm/10 deg, ADD(-S) recall at 10 % of the diameter; symmetric
// models, found by testing rotations about the model's axes, use ADD-S and the symmetric rotation
// error). edgefuse eval segments PRED.pcd TRUTH.pcd: per-object segmentation precision / recall
// against mOSD-style labels (0 invalid, 1-9 support, 20-29 object 2, 30-39 object 3, ...).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "args.hpp"
#include "failure.hpp"
#include "edgefuse/io/pcd.hpp"
#include "edgefuse/io/ply.hpp"
#include "edgefuse/io/rig.hpp"
#include "eval_poses.hpp"

namespace edgefuse::cli {
namespace {

constexpr double kPi = 3.14159265358979323846;

std::string base_name(const std::string& p) {
  const std::size_t s = p.find_last_of('/');
  return s == std::string::npos ? p : p.substr(s + 1);
}
std::string dir_name(const std::string& p) {
  const std::size_t s = p.find_last_of('/');
  return s == std::string::npos ? "." : p.substr(0, s);
}

}  // namespace

bool read_pose_lines(const std::string& path, std::vector<PoseLine>& out, std::string& err) {
  std::ifstream f(path);
  if (!f) {
    err = path + ": cannot open";
    return false;
  }
  std::string line;
  int no = 0;
  while (std::getline(f, line)) {
    ++no;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ss(line);
    std::vector<std::string> tok;
    std::string t;
    while (ss >> t) tok.push_back(t);
    if (tok.empty()) continue;
    if (tok.size() != 8 && tok.size() != 9 && tok.size() != 10) {
      err = path + ":" + std::to_string(no) + ": expected `id tx ty tz qx qy qz qw [score] [model]`, got " +
            std::to_string(tok.size()) + " fields";
      return false;
    }
    double v[8];
    for (int i = 0; i < 8; ++i) {
      char* end = nullptr;
      v[i] = std::strtod(tok[std::size_t(i)].c_str(), &end);
      if (*end != '\0' || !std::isfinite(v[i])) {
        err = path + ":" + std::to_string(no) + ": field " + std::to_string(i + 1) + " is not a number: '" +
              tok[std::size_t(i)] + "'";
        return false;
      }
    }
    PoseLine p;
    p.id = int(v[0]);
    p.T = Pose::from_tq(float(v[1]), float(v[2]), float(v[3]), float(v[4]), float(v[5]), float(v[6]), float(v[7]));
    if (tok.size() == 10) {
      p.score = std::strtof(tok[8].c_str(), nullptr);
      p.model = tok[9];
    } else if (tok.size() == 9) {
      p.model = tok[8];
    }
    out.push_back(p);
  }
  return true;
}

bool load_eval_model(const std::string& path, EvalModel& m, std::string& err) {
  io::TriangleMesh mesh;
  if (!io::read_ply(path, mesh, err)) return false;
  if (mesh.triangles.empty()) {
    m.pts = mesh.vertices;
  } else {
    double area = 0;
    for (const auto& t : mesh.triangles)
      area += 0.5 * double((mesh.vertices[t[1]] - mesh.vertices[t[0]]).cross(mesh.vertices[t[2]] - mesh.vertices[t[0]]).norm());
    const double per = 1000.0 / area;  // ~1000 samples
    double carry = 0;
    for (const auto& t : mesh.triangles) {
      const Vec3f a = mesh.vertices[t[0]], b = mesh.vertices[t[1]], c = mesh.vertices[t[2]];
      carry += 0.5 * double((b - a).cross(c - a).norm()) * per;
      const int n = int(carry);
      carry -= n;
      for (int k = 0; k < n; ++k) {
        float u = 0.5f + float(k) * 0.7548776662f, v = 0.5f + float(k) * 0.5698402910f;
        u -= std::floor(u);
        v -= std::floor(v);
        if (u + v > 1) {
          u = 1 - u;
          v = 1 - v;
        }
        m.pts.push_back(a + u * (b - a) + v * (c - a));
      }
    }
  }
  if (m.pts.size() < 4) {
    err = path + ": too few points for a model";
    return false;
  }
  Vec3f lo = m.pts[0], hi = m.pts[0];
  for (const Vec3f& p : m.pts) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  m.centre = 0.5f * (lo + hi);
  float d2 = 0;
  for (std::size_t i = 0; i < m.pts.size(); ++i)
    for (std::size_t j = i + 1; j < m.pts.size(); ++j) d2 = std::max(d2, (m.pts[i] - m.pts[j]).squaredNorm());
  m.diameter = std::sqrt(d2);
  // Sampling spacing: mean nearest-neighbour distance.
  double nn_sum = 0;
  for (std::size_t i = 0; i < m.pts.size(); ++i) {
    float best = 1e30f;
    for (std::size_t j = 0; j < m.pts.size(); ++j)
      if (i != j) best = std::min(best, (m.pts[i] - m.pts[j]).squaredNorm());
    nn_sum += std::sqrt(best);
  }
  const float spacing = float(nn_sum / double(m.pts.size()));
  auto maps_onto_itself = [&](const Mat3f& R) {
    double sum = 0;
    for (const Vec3f& p : m.pts) {
      const Vec3f q = R * (p - m.centre) + m.centre;
      float best = 1e30f;
      for (const Vec3f& r : m.pts) best = std::min(best, (q - r).squaredNorm());
      sum += std::sqrt(best);
    }
    return sum / double(m.pts.size()) < 1.5 * spacing + 0.002 * m.diameter;
  };
  m.syms.push_back(Mat3f::Identity());
  const Vec3f axes[3] = {Vec3f::UnitX(), Vec3f::UnitY(), Vec3f::UnitZ()};
  for (const Vec3f& a : axes) {
    bool continuous = true;
    for (int deg : {20, 50, 110}) continuous = continuous && maps_onto_itself(Mat3f(Eigen::AngleAxisf(float(deg * kPi / 180), a)));
    if (continuous) {
      m.cont_axes.push_back(a);
      continue;
    }
    for (int deg : {90, 180, 270}) {
      const Mat3f R(Eigen::AngleAxisf(float(deg * kPi / 180), a));
      if (maps_onto_itself(R)) m.syms.push_back(R);
    }
  }
  // Close the discrete set under composition (e.g. the box: 180 deg about x, y and z).
  for (std::size_t i = 1; i < m.syms.size(); ++i)
    for (std::size_t j = 1; j < m.syms.size() && m.syms.size() < 48; ++j) {
      const Mat3f C = m.syms[i] * m.syms[j];
      bool known = false;
      for (const Mat3f& S : m.syms) known = known || (S - C).norm() < 1e-3f;
      if (!known) m.syms.push_back(C);
    }
  return true;
}

namespace {
double angle_deg(const Mat3f& R) {
  const double c = 0.5 * (double(R.trace()) - 1.0);
  return std::acos(std::max(-1.0, std::min(1.0, c))) * 180.0 / kPi;
}

}  // namespace

PoseErrors pose_errors(const EvalModel& m, const Pose& E, const Pose& G) {
  PoseErrors e;
  e.t_mm = double((E * m.centre - G * m.centre).norm()) * 1e3;
  e.r_deg = 1e9;
  if (!m.cont_axes.empty()) {
    for (const Vec3f& a : m.cont_axes) {
      const double c = double((E.R * a).dot(G.R * a));
      double ang = std::acos(std::max(-1.0, std::min(1.0, c))) * 180.0 / kPi;
      bool flip = false;  // a 180 deg symmetry about another axis makes +a and -a equivalent
      for (const Mat3f& S : m.syms) flip = flip || (S * a).dot(a) < -0.99f;
      if (flip) ang = std::min(ang, 180.0 - ang);
      e.r_deg = std::min(e.r_deg, ang);
    }
  } else {
    for (const Mat3f& S : m.syms) e.r_deg = std::min(e.r_deg, angle_deg(E.R.transpose() * G.R * S));
  }
  double sum = 0;
  for (const Vec3f& p : m.pts) {
    const Vec3f q = E * p;
    if (m.symmetric()) {
      float best = 1e30f;
      for (const Vec3f& r : m.pts) best = std::min(best, (q - G * r).squaredNorm());
      sum += std::sqrt(best);
    } else {
      sum += (q - G * p).norm();
    }
  }
  e.add_mm = sum / double(m.pts.size()) * 1e3;
  return e;
}

namespace {
int fail(const std::string& msg) {
  std::fprintf(stderr, "edgefuse eval: %s\n", msg.c_str());
  return 1;
}

}  // namespace

int cmd_eval_poses(int argc, char** argv) {
  const char* usage =
      "usage: edgefuse eval poses EST.txt TRUE.txt [--models DIR]\n"
      "  TRUE.txt: objects.txt of a rig set (models from its rig.toml) or lines `id t q [score] model`\n";
  if (help_asked(argc, argv, usage)) return 0;
  Args args;
  std::string err;
  if (!args.parse(argc, argv, {"models"}, {}, err) || args.positional().size() != 2) {
    std::fprintf(stderr, "edgefuse eval poses: %s\n%s", err.empty() ? "expected EST and TRUE" : err.c_str(), usage);
    return 2;
  }
  const std::string est_path = args.positional()[0], true_path = args.positional()[1];
  std::vector<PoseLine> est, gt;
  if (!read_pose_lines(est_path, est, err) || !read_pose_lines(true_path, gt, err)) return fail(err);
  // Models of the true objects: their own column, else the rig.toml next to TRUE.txt.
  std::string models_dir = args.get("models", "");
  io::RigToml rig;
  bool have_rig = false;
  for (PoseLine& g : gt)
    if (g.model.empty()) {
      if (!have_rig) {
        if (!io::read_rig_toml(dir_name(true_path) + "/rig.toml", rig, err))
          return fail(true_path + ": lines without a model column need a rig.toml beside it: " + err);
        have_rig = true;
      }
      const io::RigObject* o = rig.find_object(g.id);
      if (!o) return fail(true_path + ": object id " + std::to_string(g.id) + " is not in rig.toml");
      g.model = base_name(o->model);
      if (models_dir.empty()) models_dir = dir_name(o->model_path);
    }
  if (models_dir.empty()) return fail("--models DIR is needed to find the model files");
  std::map<std::string, EvalModel> models;
  for (const PoseLine& g : gt)
    if (!models.count(g.model)) {
      EvalModel m;
      if (!load_eval_model(models_dir + "/" + g.model, m, err)) return fail(err);
      std::printf("model %s: diameter %.1f mm, %zu samples, %s\n", g.model.c_str(), m.diameter * 1e3, m.pts.size(),
                  !m.cont_axes.empty() ? "continuous symmetry (ADD-S)"
                                        : m.syms.size() > 1 ? (std::to_string(m.syms.size()) + " discrete symmetries (ADD-S)").c_str()
                                                            : "no symmetry (ADD)");
      models[g.model] = m;
    }
  std::vector<char> used(est.size(), 0);
  int ok5 = 0, ok10 = 0, okadd = 0, found = 0;
  std::vector<double> te, re;
  for (const PoseLine& g : gt) {
    const EvalModel& m = models[g.model];
    int best = -1;
    double best_d = 1e30;
    for (std::size_t k = 0; k < est.size(); ++k) {
      if (used[k] || est[k].model != g.model) continue;
      const double d = double((est[k].T * m.centre - g.T * m.centre).norm());
      if (d < best_d) {
        best_d = d;
        best = int(k);
      }
    }
    if (best < 0 || best_d > 0.5 * m.diameter) {
      std::printf("object %d (%s): not found\n", g.id, g.model.c_str());
      continue;
    }
    used[std::size_t(best)] = 1;
    ++found;
    const PoseErrors e = pose_errors(m, est[std::size_t(best)].T, g.T);
    te.push_back(e.t_mm);
    re.push_back(e.r_deg);
    const bool a5 = e.t_mm <= 5 && e.r_deg <= 5, a10 = e.t_mm <= 10 && e.r_deg <= 10,
               aa = e.add_mm <= 0.1 * m.diameter * 1e3;
    ok5 += a5;
    ok10 += a10;
    okadd += aa;
    std::printf("object %d (%s): est #%d score %.3f  t_err %.2f mm  r_err %.2f deg  %s %.2f mm (%s)%s%s\n", g.id,
                g.model.c_str(), est[std::size_t(best)].id, est[std::size_t(best)].score, e.t_mm, e.r_deg,
                m.symmetric() ? "ADD-S" : "ADD", e.add_mm, aa ? "ok" : "over 10% of diameter", a5 ? " [5mm/5deg]" : "",
                a10 ? " [10mm/10deg]" : "");
  }
  int false_pos = 0;
  for (std::size_t k = 0; k < est.size(); ++k) false_pos += !used[k];
  auto median = [](std::vector<double> v) {
    if (v.empty()) return std::nan("");
    std::sort(v.begin(), v.end());
    return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
  };
  const double n = double(gt.size());
  std::printf("recall_5mm5deg=%.3f recall_10mm10deg=%.3f add_recall=%.3f found=%d/%zu median_t_mm=%.3f "
              "median_r_deg=%.3f unmatched_estimates=%d\n",
              ok5 / n, ok10 / n, okadd / n, found, gt.size(), median(te), median(re), false_pos);
  return 0;
}

int cmd_eval_segments(int argc, char** argv) {
  // --parts: every labelled part is an object of its own (mOSD labels the geometrically disjoint parts
  // of an occluded object 10k, 10k+1, ...: its README says a model-free method cannot be expected to
  // join them); default: parts merged into their object (label / 10), the stricter reading.
  const char* usage =
      "usage: edgefuse eval segments PRED.pcd TRUTH.pcd [--parts]\n"
      "  PRED: labels per point (0 = none); TRUTH: mOSD labels (0 invalid, 1-9 support, 10k..10k+9 object k)\n"
      "  --parts: score each disjoint part (10k+i) as an object of its own instead of the whole object k\n";
  if (help_asked(argc, argv, usage)) return 0;
  const bool parts = argc == 3 && !std::strcmp(argv[2], "--parts");
  if (argc != 2 && !parts) {
    std::fputs(usage, stderr);
    return 2;
  }
  io::PointCloud pred, truth;
  std::string err;
  if (!io::read_pcd(argv[0], pred, err) || !io::read_pcd(argv[1], truth, err)) return fail(err);
  if (pred.size() != truth.size() || pred.labels.empty() || truth.labels.empty())
    return fail(std::string(argv[0]) + " and " + argv[1] + " must both have labels and the same number of points");
  std::map<uint32_t, std::map<uint32_t, std::size_t>> overlap;  // truth object -> pred label -> count
  std::map<uint32_t, std::size_t> truth_size, pred_size;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const uint32_t g = truth.labels[i] >= 20 ? (parts ? truth.labels[i] : truth.labels[i] / 10) : 0, p = pred.labels[i];
    if (g) ++truth_size[g];
    if (p) ++pred_size[p];
    if (g && p) ++overlap[g][p];
  }
  double sp = 0, sr = 0;
  for (const auto& [g, size] : truth_size) {
    uint32_t best = 0;
    std::size_t best_n = 0;
    for (const auto& [p, c] : overlap[g])
      if (c > best_n) {
        best_n = c;
        best = p;
      }
    const double prec = best ? double(best_n) / double(pred_size[best]) : 0.0, rec = double(best_n) / double(size);
    sp += prec;
    sr += rec;
    std::printf("object %u: %zu points, segment %u, precision %.3f recall %.3f\n", g, size, best, prec, rec);
  }
  const double n = double(truth_size.size());
  std::printf("seg_precision=%.4f seg_recall=%.4f objects=%zu segments=%zu\n", n ? sp / n : 0.0, n ? sr / n : 0.0,
              truth_size.size(), pred_size.size());
  return 0;
}

}  // namespace edgefuse::cli
