// The sim rig's key-pose path (sensors.sim_path): keys read from a TUM-format file, eased
// lerp/slerp between keys (at rest at every key), holds at repeated keys, and a bad file refused
// with its name and line.
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "edgefuse/hal/null/null_backends.hpp"
#include "edgefuse/hal/sim/sim_depth_camera.hpp"
#include "edgefuse/hal/sim/sim_rig_path.hpp"
#include "test_support.hpp"

using namespace edgefuse;
using namespace edgefuse::hal;

namespace {

std::string write_file(const char* text) {
  static int n = 0;
  const std::string p = "/tmp/edgefuse_test_rig_path_" + std::to_string(::getpid()) + "_" + std::to_string(n++);
  std::FILE* f = std::fopen(p.c_str(), "w");
  std::fputs(text, f);
  std::fclose(f);
  return p;
}

float angle_deg(const Pose& a, const Pose& b) {
  return a.quaternion().angularDistance(b.quaternion()) * 180.0f / 3.14159265f;
}

// Straight down at 0.7 m; then 20 deg about x, 0.1 m along x; held 1 s at each.
const char* kTwoStations =
    "# stamp tx ty tz qx qy qz qw\n"
    "10.0 0 0 0.7 1 0 0 0\n"
    "11.0 0 0 0.7 1 0 0 0\n"
    "\n"
    "13.0 0.1 0 0.7 0.98480775 0 0 0.17364818  # 180 deg about x, then 20 deg more\n"
    "14.0 0.1 0 0.7 0.98480775 0 0 0.17364818\n";

}  // namespace

TEST_GROUP(SimRigPath){};

TEST(SimRigPath, HoldsAtRepeatedKeysAndEasesBetweenThem) {
  const std::string file = write_file(kTwoStations);
  SimRigPath path;
  std::string err;
  CHECK_TRUE_TEXT(load_sim_rig_path(file, path, err), err.c_str());
  CHECK_EQUAL(4, path.count);
  DOUBLES_EQUAL(4.0, path.duration_s(), 1e-9);  // stamps relative to the first key
  // Held: before the path, during the first station, after the last key.
  CHECK(path.at(-1.0).t.isApprox(path.pose[0].t));
  CHECK(path.at(0.7).t.isApprox(path.pose[0].t));
  CHECK(path.at(99.0).t.isApprox(path.pose[3].t));
  DOUBLES_EQUAL(0.0, angle_deg(path.at(0.5), path.pose[0]), 1e-3);
  // Halfway through the move: half the translation and half the rotation (the easing is symmetric).
  const Pose mid = path.at(2.0);
  DOUBLES_EQUAL(0.05, mid.t.x(), 1e-6);
  DOUBLES_EQUAL(10.0, angle_deg(mid, path.pose[0]), 1e-3);
  // Eased: a quarter of the time covers less than a quarter of the way (smoothstep: 0.15625).
  DOUBLES_EQUAL(0.015625, path.at(1.5).t.x(), 1e-6);
  // At rest at a key: 1 ms after leaving, the rig moved a few um at most.
  CHECK(path.at(1.001).t.x() < 1e-5);
  std::remove(file.c_str());
}

TEST(SimRigPath, ABadLineNamesTheFileAndTheLine) {
  const std::string file = write_file("0 0 0 0.7 1 0 0 0\n1 0 0 0.7 1 0 0\n");
  SimRigPath path;
  std::string err;
  CHECK_FALSE(load_sim_rig_path(file, path, err));
  CHECK_EQUAL(0, path.count);
  STRCMP_CONTAINS((file + " (line 2)").c_str(), err.c_str());
  STRCMP_CONTAINS("8 numbers", err.c_str());
  std::remove(file.c_str());
}

TEST(SimRigPath, StampsMustIncreaseAndQuaternionsHaveLength) {
  SimRigPath path;
  std::string err;
  const std::string back = write_file("1 0 0 0.7 1 0 0 0\n1 0 0 0.7 1 0 0 0\n");
  CHECK_FALSE(load_sim_rig_path(back, path, err));
  STRCMP_CONTAINS("(line 2): the stamp is not after", err.c_str());
  const std::string zero = write_file("0 0 0 0.7 0 0 0 0\n");
  CHECK_FALSE(load_sim_rig_path(zero, path, err));
  STRCMP_CONTAINS("(line 1): the quaternion has no length", err.c_str());
  CHECK_FALSE(load_sim_rig_path("/nonexistent/path.txt", path, err));
  STRCMP_CONTAINS("/nonexistent/path.txt: cannot open", err.c_str());
  std::remove(back.c_str());
  std::remove(zero.c_str());
}

TEST(SimRigPath, RefusesMoreKeysThanItsCapacity) {
  std::string text;
  for (int i = 0; i <= kSimRigPathKeysMax; ++i) text += std::to_string(i) + " 0 0 0.7 1 0 0 0\n";
  const std::string file = write_file(text.c_str());
  SimRigPath path;
  std::string err;
  CHECK_FALSE(load_sim_rig_path(file, path, err));
  STRCMP_CONTAINS("(line 65): more than 64 keys", err.c_str());
  std::remove(file.c_str());
}

TEST(SimRigPath, TheSimCameraFollowsIt) {
  const std::string file = write_file(kTwoStations);
  SimRigPath path;
  std::string err;
  CHECK_TRUE_TEXT(load_sim_rig_path(file, path, err), err.c_str());
  SimScene scene;
  default_bin_scene(scene);
  ManualClock clock;
  SimDepthCameraConfig cfg = sim_xtion_config();
  cfg.rig_path = &path;
  SimDepthCamera cam(cfg, scene, clock);
  CHECK(cam.start(0) == HalStatus::kOk);
  // Frame 90 is 3 s after the start at 30 Hz: the move has ended at the second station.
  CHECK(cam.pose_of(90).t.isApprox(path.pose[2].t, 1e-5f));
  DOUBLES_EQUAL(0.0, angle_deg(cam.pose_of(90), path.pose[2]), 1e-3);
  CHECK(cam.pose_of(0).t.isApprox(path.pose[0].t, 1e-5f));
  std::remove(file.c_str());
}
