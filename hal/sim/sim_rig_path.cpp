#include "edgefuse/hal/sim/sim_rig_path.hpp"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>

namespace edgefuse::hal {

namespace {

// 0 -> 0, 1 -> 1 with zero slope at both ends: the rig starts and stops at rest.
double smoothstep(double s) { return s * s * (3.0 - 2.0 * s); }

bool blank_or_comment(const char* line) {
  const char* p = line;
  while (*p == ' ' || *p == '\t' || *p == '\r' || *p == '\n') ++p;
  return *p == '\0' || *p == '#';
}

// One key line; false when it is not exactly eight numbers.
//! \param line the text  \param v receives stamp, tx, ty, tz, qx, qy, qz, qw
bool parse_key(const char* line, double v[8]) {
  int used = 0;
  if (std::sscanf(line, " %lf %lf %lf %lf %lf %lf %lf %lf %n", &v[0], &v[1], &v[2], &v[3], &v[4], &v[5], &v[6],
                  &v[7], &used) != 8)
    return false;
  return line[used] == '\0' || line[used] == '#';
}

}  // namespace

Pose SimRigPath::at(double t_s) const {
  if (count == 0) return Pose::identity();
  if (t_s <= stamp_s[0]) return pose[0];
  if (t_s >= stamp_s[count - 1]) return pose[count - 1];
  int hi = 1;
  while (stamp_s[hi] < t_s) ++hi;
  const int lo = hi - 1;
  const float s = float(smoothstep((t_s - stamp_s[lo]) / (stamp_s[hi] - stamp_s[lo])));
  const Eigen::Quaternionf q = pose[lo].quaternion().slerp(s, pose[hi].quaternion());
  Pose p;
  p.R = q.normalized().toRotationMatrix();
  p.t = pose[lo].t + s * (pose[hi].t - pose[lo].t);
  return p;
}

bool load_sim_rig_path(const std::string& file, SimRigPath& out, std::string& err) {
  out.count = 0;
  std::FILE* f = std::fopen(file.c_str(), "r");
  if (f == nullptr) {
    err = file + ": cannot open: " + std::strerror(errno);
    return false;
  }
  char line[512];
  int line_no = 0;
  double first_stamp = 0;
  auto fail = [&](const char* why) {
    err = file + " (line " + std::to_string(line_no) + "): " + why;
    out.count = 0;
    std::fclose(f);
    return false;
  };
  while (std::fgets(line, sizeof(line), f) != nullptr) {
    ++line_no;
    if (std::strchr(line, '\n') == nullptr && !std::feof(f)) return fail("line longer than 511 characters");
    if (blank_or_comment(line)) continue;
    double v[8];
    if (!parse_key(line, v)) return fail("expected 'stamp tx ty tz qx qy qz qw' (8 numbers)");
    if (out.count == kSimRigPathKeysMax) return fail("more than 64 keys");
    const double qn = std::sqrt(v[4] * v[4] + v[5] * v[5] + v[6] * v[6] + v[7] * v[7]);
    if (!(qn > 1e-6) || !std::isfinite(qn)) return fail("the quaternion has no length");
    if (out.count == 0) first_stamp = v[0];
    const double t_s = v[0] - first_stamp;
    if (out.count > 0 && !(t_s > out.stamp_s[out.count - 1])) return fail("the stamp is not after the previous key's");
    out.stamp_s[out.count] = t_s;
    out.pose[out.count] = Pose::from_tq(float(v[1]), float(v[2]), float(v[3]), float(v[4] / qn), float(v[5] / qn),
                                        float(v[6] / qn), float(v[7] / qn));
    ++out.count;
  }
  std::fclose(f);
  if (out.count == 0) {
    err = file + ": no key pose ('stamp tx ty tz qx qy qz qw' lines)";
    return false;
  }
  return true;
}

}  // namespace edgefuse::hal
