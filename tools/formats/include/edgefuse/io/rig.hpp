// Rig data sets (FORMATS.md section 4): rig.toml, objects.txt, extrinsics.txt and the line
// scanner's profiles.txt. Every reader checks ranges and names the file (and line) in its errors.
#pragma once

#include <cmath>
#include <cstddef>
#include <string>
#include <vector>

#include "edgefuse/math/pose.hpp"
#include "edgefuse/sensor/pinhole.hpp"

namespace edgefuse::io {

enum class SensorKind { kPinhole, kLineScanner };

//! A 2D profile scanner: beam i at theta_i = -fov/2 + i * fov / (beams - 1) in the sensor's x'z'
//! plane, direction (sin theta, 0, cos theta).
struct LineScannerParams {
  int beams = 0;
  float fov_deg = 0;
  float min_range_m = 0;
  float max_range_m = 0;

  float beam_angle_rad(int i) const {
    const float fov = fov_deg * 3.14159265358979323846f / 180.0f;
    return -0.5f * fov + float(i) * fov / float(beams - 1);
  }
  Vec3f beam_direction(int i) const {
    const float a = beam_angle_rad(i);
    return Vec3f(std::sin(a), 0.0f, std::cos(a));
  }
};

struct RigSensor {
  std::string name;  //!< also the sensor's folder name
  SensorKind kind = SensorKind::kPinhole;
  PinholeIntrinsics pinhole;  //!< kind == kPinhole
  bool color = false;         //!< pinhole: rgb/ + rgb.txt present (registered to depth)
  bool amplitude = false;     //!< pinhole: amplitude/ + amplitude.txt present
  LineScannerParams line;     //!< kind == kLineScanner
};

struct RigObject {
  int id = 0;
  std::string model;       //!< as written in rig.toml (relative to the set's folder)
  std::string model_path;  //!< resolved path
};

struct RigToml {
  std::string root;  //!< folder of rig.toml
  std::string name;
  std::vector<RigSensor> sensors;
  std::vector<RigObject> objects;

  const RigSensor* find_sensor(const std::string& name) const;
  const RigObject* find_object(int id) const;
};

//! Parses rig.toml: unique, folder-safe sensor names; kind "pinhole" (fields as camera.toml plus
//! color/amplitude flags, ranges required) or "line_scanner" (beams >= 2, 0 < fov_deg < 360,
//! 0 <= min_range < max_range); unique object ids >= 0 with a relative model path.
bool read_rig_toml(const std::string& path, RigToml& rig, std::string& err);

struct ObjectPose {
  int id = 0;
  Pose T_world_object;
};
//! objects.txt: "id tx ty tz qx qy qz qw" per line (ids unique).
bool read_objects_txt(const std::string& path, std::vector<ObjectPose>& objects, std::string& err);

struct SensorExtrinsic {
  std::string sensor_a, sensor_b;
  Pose T_a_b;  //!< pose of sensor_b in sensor_a's frame
};
//! extrinsics.txt: "sensor_a sensor_b tx ty tz qx qy qz qw" per line.
bool read_extrinsics_txt(const std::string& path, std::vector<SensorExtrinsic>& extrinsics, std::string& err);

//! Profiles of a line scanner, stored flat: profile p's ranges are ranges[p * beams .. + beams).
struct ProfileSet {
  int beams = 0;
  std::vector<double> stamps_s;
  std::vector<float> ranges_m;  //!< 0 = no return
  std::size_t size() const { return stamps_s.size(); }
  const float* profile(std::size_t p) const { return ranges_m.data() + p * std::size_t(beams); }
};
//! profiles.txt: "timestamp r_0 .. r_{beams-1}" per line, exactly `beams` finite ranges >= 0,
//! stamps increasing. Errors name the file and line.
bool read_profiles_txt(const std::string& path, int beams, ProfileSet& profiles, std::string& err);

//! A line scanner's recording: profiles plus the sensor-to-world pose of each (nearest stamp from
//! groundtruth.txt within 0.02 s; has_pose[p] false when none).
struct LineScan {
  RigSensor sensor;
  ProfileSet profiles;
  std::vector<char> has_pose;
  std::vector<Pose> T_world_sensor;
};
bool open_line_scan(const RigToml& rig, const std::string& sensor_name, LineScan& scan, std::string& err);

//! The whole set: rig.toml + objects.txt + extrinsics.txt (both optional), cross-checked
//! (object ids in rig.toml, sensor names known).
struct RigSet {
  RigToml rig;
  std::vector<ObjectPose> objects;
  std::vector<SensorExtrinsic> extrinsics;
};
bool open_rig_set(const std::string& folder, RigSet& set, std::string& err);

}  // namespace edgefuse::io
