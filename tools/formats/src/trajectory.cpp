// TUM trajectories and associate.py-style timestamp matching.
#include "edgefuse/io/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <exception>
#include <new>
#include <tuple>

#include "file_util.hpp"
#include "pose_text.hpp"
#include "text_util.hpp"

namespace edgefuse::io {

using detail::format;

bool read_tum_trajectory(const std::string& path, std::vector<StampedPose>& poses, std::string& err) {
  return detail::guarded(path, err, [&] {
    std::string text;
    if (!detail::read_file(path, text, err)) return false;
    if (text.empty()) {
      err = path + ": empty file, expected a TUM trajectory";
      return false;
    }
    std::vector<StampedPose> out;
    std::vector<std::string_view> tok;
    detail::LineReader lines(text);
    std::string_view line;
    bool sorted = true;
    while (lines.next(line)) {
      if (detail::is_blank_or_comment(line)) continue;
      detail::split_ws(line, tok);
      if (tok.size() != 8) {
        err = format("%s:%d: expected 8 values (timestamp tx ty tz qx qy qz qw), got %zu", path.c_str(),
                     lines.line_number(), tok.size());
        return false;
      }
      StampedPose sp;
      std::string why;
      if (!detail::parse_double(tok[0], sp.stamp_s) || !std::isfinite(sp.stamp_s)) {
        err = format("%s:%d: bad timestamp %s", path.c_str(), lines.line_number(), detail::quote(tok[0]).c_str());
        return false;
      }
      if (!detail::pose_from_tq_tokens(&tok[1], sp.T, why)) {
        err = format("%s:%d: %s", path.c_str(), lines.line_number(), why.c_str());
        return false;
      }
      if (!out.empty() && sp.stamp_s < out.back().stamp_s) sorted = false;
      out.push_back(sp);
    }
    if (out.empty()) {
      err = path + ": no poses (only comments or blank lines)";
      return false;
    }
    if (!sorted)
      std::stable_sort(out.begin(), out.end(),
                       [](const StampedPose& a, const StampedPose& b) { return a.stamp_s < b.stamp_s; });
    poses.swap(out);
    return true;
  });
}

bool write_tum_trajectory(const std::string& path, const std::vector<StampedPose>& poses, std::string& err,
                          const std::string& comment) {
  std::string s;
  if (!comment.empty()) s += "# " + comment + "\n";
  s += "# timestamp tx ty tz qx qy qz qw\n";
  for (const StampedPose& p : poses) {
    const Eigen::Quaternionf q = p.T.quaternion();
    s += format("%.6f %.9g %.9g %.9g %.9g %.9g %.9g %.9g\n", p.stamp_s, p.T.t.x(), p.T.t.y(), p.T.t.z(), q.x(),
                q.y(), q.z(), q.w());
  }
  return detail::write_file(path, s.data(), s.size(), err);
}

long find_nearest_stamp(const std::vector<double>& stamps, double stamp_s, double max_dt_s) {
  if (stamps.empty()) return -1;
  const auto it = std::lower_bound(stamps.begin(), stamps.end(), stamp_s);
  long best = -1;
  double best_dt = max_dt_s;
  const long i = long(it - stamps.begin());
  for (long j : {i - 1, i}) {
    if (j < 0 || j >= long(stamps.size())) continue;
    const double dt = std::fabs(stamps[std::size_t(j)] - stamp_s);
    if (dt < best_dt) {
      best_dt = dt;
      best = j;
    }
  }
  return best;
}

const StampedPose* find_nearest(const std::vector<StampedPose>& poses, double stamp_s, double max_dt_s) {
  const auto it = std::lower_bound(poses.begin(), poses.end(), stamp_s,
                                   [](const StampedPose& p, double t) { return p.stamp_s < t; });
  const StampedPose* best = nullptr;
  double best_dt = max_dt_s;
  for (auto c : {it - (it == poses.begin() ? 0 : 1), it}) {
    if (c == poses.end()) continue;
    const double dt = std::fabs(c->stamp_s - stamp_s);
    if (dt < best_dt) {
      best_dt = dt;
      best = &*c;
    }
  }
  return best;
}

std::vector<long> associate_stamps(const std::vector<double>& a, const std::vector<double>& b, double max_dt_s) {
  // Candidate pairs within max_dt_s, found with a sliding window over sorted copies of b.
  std::vector<std::pair<double, std::size_t>> bs(b.size());
  for (std::size_t j = 0; j < b.size(); ++j) bs[j] = {b[j], j};
  std::sort(bs.begin(), bs.end());
  std::vector<std::tuple<double, std::size_t, std::size_t>> cand;
  for (std::size_t i = 0; i < a.size(); ++i) {
    auto it = std::lower_bound(bs.begin(), bs.end(), std::make_pair(a[i] - max_dt_s, std::size_t(0)));
    for (; it != bs.end() && it->first < a[i] + max_dt_s; ++it) {
      const double dt = std::fabs(it->first - a[i]);
      if (dt < max_dt_s) cand.emplace_back(dt, i, it->second);
    }
  }
  std::sort(cand.begin(), cand.end());
  std::vector<long> match(a.size(), -1);
  std::vector<char> used(b.size(), 0);
  for (const auto& [dt, i, j] : cand) {
    (void)dt;
    if (match[i] >= 0 || used[j]) continue;
    match[i] = long(j);
    used[j] = 1;
  }
  return match;
}

}  // namespace edgefuse::io
