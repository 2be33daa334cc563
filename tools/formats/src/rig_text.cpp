// The text files of a rig set: objects.txt, extrinsics.txt, a line scanner's profiles.txt, and
// the whole-set loaders that cross-check them against rig.toml.
#include <cmath>
#include <exception>
#include <new>

#include "edgefuse/io/rig.hpp"
#include "edgefuse/io/trajectory.hpp"
#include "file_util.hpp"
#include "pose_text.hpp"
#include "text_util.hpp"

namespace edgefuse::io {

using detail::format;

namespace {

// Calls f(line_number, tokens) for each non-comment line; false stops with f's error.
template <class F>
bool for_each_record(const std::string& path, const char* what, std::string& err, F&& f) {
  std::string text;
  if (!detail::read_file(path, text, err)) return false;
  if (text.empty()) {
    err = path + ": empty file, expected " + what;
    return false;
  }
  std::vector<std::string_view> tok;
  detail::LineReader lines(text);
  std::string_view line;
  while (lines.next(line)) {
    if (detail::is_blank_or_comment(line)) continue;
    detail::split_ws(line, tok);
    if (!f(lines.line_number(), tok)) return false;
  }
  return true;
}

}  // namespace

bool read_objects_txt(const std::string& path, std::vector<ObjectPose>& objects, std::string& err) {
  return detail::guarded(path, err, [&] {
    std::vector<ObjectPose> out;
    const bool ok = for_each_record(path, "object poses", err, [&](int ln, const std::vector<std::string_view>& t) {
      if (t.size() != 8) {
        err = format("%s:%d: expected 8 values (id tx ty tz qx qy qz qw), got %zu", path.c_str(), ln, t.size());
        return false;
      }
      int64_t id = 0;
      if (!detail::parse_int64(t[0], id) || id < 0 || id > 2147483647) {
        err = format("%s:%d: bad object id %s", path.c_str(), ln, detail::quote(t[0]).c_str());
        return false;
      }
      ObjectPose o;
      o.id = int(id);
      std::string why;
      if (!detail::pose_from_tq_tokens(&t[1], o.T_world_object, why)) {
        err = format("%s:%d: %s", path.c_str(), ln, why.c_str());
        return false;
      }
      for (const ObjectPose& p : out)
        if (p.id == o.id) {
          err = format("%s:%d: object id %d listed twice", path.c_str(), ln, o.id);
          return false;
        }
      out.push_back(o);
      return true;
    });
    if (ok) objects.swap(out);
    return ok;
  });
}

bool read_extrinsics_txt(const std::string& path, std::vector<SensorExtrinsic>& extrinsics, std::string& err) {
  return detail::guarded(path, err, [&] {
    std::vector<SensorExtrinsic> out;
    const bool ok = for_each_record(path, "sensor extrinsics", err, [&](int ln, const std::vector<std::string_view>& t) {
      if (t.size() != 9) {
        err = format("%s:%d: expected 9 values (sensor_a sensor_b tx ty tz qx qy qz qw), got %zu", path.c_str(), ln,
                     t.size());
        return false;
      }
      SensorExtrinsic e;
      e.sensor_a = std::string(t[0]);
      e.sensor_b = std::string(t[1]);
      std::string why;
      if (!detail::pose_from_tq_tokens(&t[2], e.T_a_b, why)) {
        err = format("%s:%d: %s", path.c_str(), ln, why.c_str());
        return false;
      }
      out.push_back(e);
      return true;
    });
    if (ok) extrinsics.swap(out);
    return ok;
  });
}

bool read_profiles_txt(const std::string& path, int beams, ProfileSet& profiles, std::string& err) {
  return detail::guarded(path, err, [&] {
    if (beams < 2) {
      err = format("%s: cannot read profiles of %d beams", path.c_str(), beams);
      return false;
    }
    ProfileSet out;
    out.beams = beams;
    const bool ok = for_each_record(path, "laser profiles", err, [&](int ln, const std::vector<std::string_view>& t) {
      if (t.size() != std::size_t(beams) + 1) {
        err = format("%s:%d: expected %d values (a timestamp and %d ranges), got %zu", path.c_str(), ln, beams + 1, beams,
                     t.size());
        return false;
      }
      double stamp = 0;
      if (!detail::parse_double(t[0], stamp) || !std::isfinite(stamp)) {
        err = format("%s:%d: bad timestamp %s", path.c_str(), ln, detail::quote(t[0]).c_str());
        return false;
      }
      if (!out.stamps_s.empty() && !(stamp > out.stamps_s.back())) {
        err = format("%s:%d: timestamp %.6f is not after the previous %.6f", path.c_str(), ln, stamp,
                     out.stamps_s.back());
        return false;
      }
      for (int i = 0; i < beams; ++i) {
        float r = 0;
        if (!detail::parse_float(t[std::size_t(i) + 1], r) || !std::isfinite(r) || r < 0) {
          err = format("%s:%d: range %d is %s, expected a finite number >= 0", path.c_str(), ln, i,
                       detail::quote(t[std::size_t(i) + 1]).c_str());
          return false;
        }
        out.ranges_m.push_back(r);
      }
      out.stamps_s.push_back(stamp);
      return true;
    });
    if (!ok) return false;
    if (out.stamps_s.empty()) {
      err = path + ": no profiles (only comments or blank lines)";
      return false;
    }
    profiles = std::move(out);
    return true;
  });
}

bool open_line_scan(const RigToml& rig, const std::string& sensor_name, LineScan& scan, std::string& err) {
  const std::string rig_path = detail::join_path(rig.root, "rig.toml");
  const RigSensor* s = rig.find_sensor(sensor_name);
  if (!s) {
    err = rig_path + ": no sensor named '" + sensor_name + "'";
    return false;
  }
  if (s->kind != SensorKind::kLineScanner) {
    err = rig_path + ": sensor '" + sensor_name + "' is not a line_scanner";
    return false;
  }
  return detail::guarded(rig_path, err, [&] {
    LineScan out;
    out.sensor = *s;
    const std::string dir = detail::join_path(rig.root, s->name);
    if (!read_profiles_txt(detail::join_path(dir, "profiles.txt"), s->line.beams, out.profiles, err)) return false;
    out.has_pose.assign(out.profiles.size(), 0);
    out.T_world_sensor.assign(out.profiles.size(), Pose());
    const std::string gt = detail::join_path(dir, "groundtruth.txt");
    if (detail::is_regular_file(gt)) {
      std::vector<StampedPose> poses;
      if (!read_tum_trajectory(gt, poses, err)) return false;
      for (std::size_t p = 0; p < out.profiles.size(); ++p) {
        if (const StampedPose* sp = find_nearest(poses, out.profiles.stamps_s[p])) {
          out.has_pose[p] = 1;
          out.T_world_sensor[p] = sp->T;
        }
      }
    }
    scan = std::move(out);
    return true;
  });
}

bool open_rig_set(const std::string& folder, RigSet& set, std::string& err) {
  const std::string rig_path = detail::join_path(folder, "rig.toml");
  return detail::guarded(rig_path, err, [&] {
    RigSet out;
    if (!read_rig_toml(rig_path, out.rig, err)) return false;
    const std::string obj_path = detail::join_path(folder, "objects.txt");
    if (detail::is_regular_file(obj_path)) {
      if (!read_objects_txt(obj_path, out.objects, err)) return false;
      for (const ObjectPose& o : out.objects)
        if (!out.rig.find_object(o.id)) {
          err = format("%s: object id %d has no [[object]] in %s", obj_path.c_str(), o.id, rig_path.c_str());
          return false;
        }
    }
    const std::string ext_path = detail::join_path(folder, "extrinsics.txt");
    if (detail::is_regular_file(ext_path)) {
      if (!read_extrinsics_txt(ext_path, out.extrinsics, err)) return false;
      for (const SensorExtrinsic& e : out.extrinsics)
        for (const std::string* n : {&e.sensor_a, &e.sensor_b})
          if (!out.rig.find_sensor(*n)) {
            err = ext_path + ": sensor '" + *n + "' is not in " + rig_path;
            return false;
          }
    }
    set = std::move(out);
    return true;
  });
}

}  // namespace edgefuse::io
