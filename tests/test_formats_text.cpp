// Whitespace text formats: TUM trajectories, 4x4 pose files, objects.txt, extrinsics.txt and a
// line scanner's profiles.txt; timestamp association.
#include <cmath>
#include <string>
#include <vector>

#include "edgefuse/io/rig.hpp"
#include "edgefuse/io/trajectory.hpp"
#include "formats_test_util.hpp"

using namespace edgefuse;
using namespace formats_test;

namespace {

const char* kTraj =
    "# ground truth trajectory\n"
    "# timestamp tx ty tz qx qy qz qw\n"
    "1305031098.6659 1.3563 0.6305 1.6380 0.6132 0.5962 -0.3311 -0.3986\n"
    "1305031098.6758 1.3543 0.6306 1.6360 0.6129 0.5966 -0.3316 -0.3980\n"
    "\n"
    "1305031098.6858 1.3524 0.6304 1.6345 0.6126 0.5967 -0.3323 -0.3979\n";

const Reader read_traj = [](const std::string& p, std::string& e) {
  std::vector<io::StampedPose> v;
  return io::read_tum_trajectory(p, v, e);
};
const Reader read_objects = [](const std::string& p, std::string& e) {
  std::vector<io::ObjectPose> v;
  return io::read_objects_txt(p, v, e);
};
const Reader read_extr = [](const std::string& p, std::string& e) {
  std::vector<io::SensorExtrinsic> v;
  return io::read_extrinsics_txt(p, v, e);
};
const Reader read_pose = [](const std::string& p, std::string& e) {
  Pose T;
  return io::read_pose_matrix_txt(p, T, e);
};

std::string profiles_text(int n, int beams) {
  std::string s = "# timestamp r_0 ...\n";
  for (int p = 0; p < n; ++p) {
    s += std::to_string(1000 + p) + ".5";
    for (int i = 0; i < beams; ++i) s += i % 3 ? " 0.223404" : " 0";
    s += "\n";
  }
  return s;
}

}  // namespace

TEST_GROUP(FormatsText) {
  TempDir dir;
};

TEST(FormatsText, TrajectoryReadWriteRoundTrip) {
  const std::string path = dir.file("gt.txt");
  write_bytes(path, kTraj);
  std::vector<io::StampedPose> poses;
  std::string err;
  CHECK_TEXT(io::read_tum_trajectory(path, poses, err), err.c_str());
  LONGS_EQUAL(3, long(poses.size()));
  DOUBLES_EQUAL(1305031098.6758, poses[1].stamp_s, 1e-6);
  DOUBLES_EQUAL(1.3543, poses[1].T.t.x(), 1e-6);
  const Eigen::Quaternionf q = poses[0].T.quaternion();  // w >= 0: the file's q negated
  DOUBLES_EQUAL(-0.6132, q.x(), 1e-3);
  DOUBLES_EQUAL(0.3986, q.w(), 1e-3);
  const std::string out = dir.file("out.txt");
  CHECK_TEXT(io::write_tum_trajectory(out, poses, err, "test"), err.c_str());
  std::vector<io::StampedPose> back;
  CHECK_TEXT(io::read_tum_trajectory(out, back, err), err.c_str());
  LONGS_EQUAL(3, long(back.size()));
  for (std::size_t i = 0; i < 3; ++i) {
    DOUBLES_EQUAL(poses[i].stamp_s, back[i].stamp_s, 1e-6);
    CHECK((poses[i].T.matrix() - back[i].T.matrix()).cwiseAbs().maxCoeff() < 1e-6f);
  }
  // Unsorted input comes back sorted.
  write_bytes(path, "2 0 0 0 0 0 0 1\n1 1 0 0 0 0 0 1\n");
  CHECK(io::read_tum_trajectory(path, poses, err));
  DOUBLES_EQUAL(1.0, poses[0].stamp_s, 0);
  DOUBLES_EQUAL(1.0, poses[0].T.t.x(), 0);
}

TEST(FormatsText, NearestAndAssociate) {
  std::vector<io::StampedPose> poses(3);
  poses[0].stamp_s = 1.00;
  poses[1].stamp_s = 1.01;
  poses[2].stamp_s = 1.05;
  CHECK(io::find_nearest(poses, 1.004) == &poses[0]);
  CHECK(io::find_nearest(poses, 1.006) == &poses[1]);
  CHECK(io::find_nearest(poses, 1.04) == &poses[2]);
  CHECK(io::find_nearest(poses, 0.95) == nullptr);
  CHECK(io::find_nearest(poses, 1.08) == nullptr);
  CHECK(io::find_nearest(std::vector<io::StampedPose>(), 1.0) == nullptr);
  LONGS_EQUAL(1, io::find_nearest_stamp({1.0, 1.01, 1.05}, 1.006));
  LONGS_EQUAL(-1, io::find_nearest_stamp({1.0, 1.01, 1.05}, 2.0));
  // associate.py: one to one, closest pairs first.
  const std::vector<long> m = io::associate_stamps({1.000, 1.004, 2.0}, {1.003, 1.02});
  LONGS_EQUAL(3, long(m.size()));
  LONGS_EQUAL(-1, m[0]);  // loses 1.003 to the closer 1.004; 1.02 is not closer than 0.02
  LONGS_EQUAL(0, m[1]);
  LONGS_EQUAL(-1, m[2]);
}

TEST(FormatsText, TrajectoryBadLines) {
  check_bad_text(dir, "gt.txt", "1 2 3 4 5 6 7\n", read_traj, "gt.txt:1: expected 8 values");
  check_bad_text(dir, "gt.txt", "# c\n1 2 3 4 0 0 0 1 9\n", read_traj, "gt.txt:2: expected 8 values");
  check_bad_text(dir, "gt.txt", "x 0 0 0 0 0 0 1\n", read_traj, "gt.txt:1: bad timestamp 'x'");
  check_bad_text(dir, "gt.txt", "1 0 nan 0 0 0 0 1\n", read_traj, "not a finite number: 'nan'");
  check_bad_text(dir, "gt.txt", "1 0 0 0 0 0 0 0\n", read_traj, "has norm 0, expected 1");
  check_bad_text(dir, "gt.txt", "1 0 0 0 1 1 0 0\n", read_traj, "has norm 1.41421");
  check_bad_text(dir, "gt.txt", "# only comments\n\n", read_traj, "no poses");
  check_bad_files(dir, "gt.txt", read_traj, "1305031098.6659 1.3563");
  check_truncations(dir, "cut.txt", kTraj, read_traj, false);
}

TEST(FormatsText, PoseMatrix) {
  const std::string path = dir.file("frame-000000.pose.txt");
  write_bytes(path, "0 -1 0 1\n1 0 0 2\n0 0 1 3\n0 0 0 1\n");
  Pose T;
  std::string err;
  CHECK_TEXT(io::read_pose_matrix_txt(path, T, err), err.c_str());
  const Vec3f p = T * Vec3f(1, 0, 0);
  CHECK((p - Vec3f(1, 3, 3)).norm() < 1e-6f);
  check_bad_text(dir, "p.txt", "1 0 0 0\n0 1 0 0\n0 0 1 0\n", read_pose, "holds 12 numbers, expected 16");
  check_bad_text(dir, "p.txt", "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1 5\n", read_pose, "more than 16");
  check_bad_text(dir, "p.txt", "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 1 1\n", read_pose, "last row is 0 0 1 1");
  check_bad_text(dir, "p.txt", "2 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n", read_pose, "not a rotation");
  check_bad_text(dir, "p.txt", "-1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n", read_pose, "not a rotation");
  check_bad_text(dir, "p.txt", "1 0 0 0\n0 1 0 0\n0 0 1 -inf\n0 0 0 1\n", read_pose, "p.txt:3: not a finite number");
  check_bad_files(dir, "p.txt", read_pose, "1 0 0 ");
  check_truncations(dir, "cut.txt", "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n", read_pose, false);
}

TEST(FormatsText, ObjectsAndExtrinsics) {
  const std::string obj = dir.file("objects.txt");
  write_bytes(obj, "1 -0.038 -0.010 0.066 -0.531051488 -0.637515883 -0.233326854 0.507066460\n"
                   "6 0.13 0.07 0.0125 0 0 -0.243293857 0.969952627\n");
  std::vector<io::ObjectPose> objects;
  std::string err;
  CHECK_TEXT(io::read_objects_txt(obj, objects, err), err.c_str());
  LONGS_EQUAL(2, long(objects.size()));
  LONGS_EQUAL(6, objects[1].id);
  DOUBLES_EQUAL(0.0125, objects[1].T_world_object.t.z(), 1e-7);
  check_bad_text(dir, "o.txt", "1 0 0 0 0 0 0 1\n1 0 0 0 0 0 0 1\n", read_objects, "o.txt:2: object id 1 listed twice");
  check_bad_text(dir, "o.txt", "-1 0 0 0 0 0 0 1\n", read_objects, "o.txt:1: bad object id '-1'");
  check_bad_text(dir, "o.txt", "1.5 0 0 0 0 0 0 1\n", read_objects, "bad object id '1.5'");
  check_bad_text(dir, "o.txt", "1 0 0 0 0 0 1\n", read_objects, "o.txt:1: expected 8 values");
  check_bad_files(dir, "o.txt", read_objects, "1 0.5 ");

  const std::string ext = dir.file("extrinsics.txt");
  write_bytes(ext, "xtion tof 0.057331683 0.007282130 -0.000631202 -0.013420469 -0.018716886 0.019022853 0.999553751\n");
  std::vector<io::SensorExtrinsic> e;
  CHECK_TEXT(io::read_extrinsics_txt(ext, e, err), err.c_str());
  STRCMP_EQUAL("tof", e[0].sensor_b.c_str());
  DOUBLES_EQUAL(0.057331683, e[0].T_a_b.t.x(), 1e-7);
  check_bad_text(dir, "e.txt", "xtion 0 0 0 0 0 0 1\n", read_extr, "e.txt:1: expected 9 values");
  check_bad_text(dir, "e.txt", "a b 0 0 0 0 0 0 2\n", read_extr, "has norm 2");
  check_bad_files(dir, "e.txt", read_extr, "xtion tof ");
}

TEST(FormatsText, Profiles) {
  const std::string path = dir.file("profiles.txt");
  write_bytes(path, profiles_text(4, 8));
  io::ProfileSet ps;
  std::string err;
  CHECK_TEXT(io::read_profiles_txt(path, 8, ps, err), err.c_str());
  LONGS_EQUAL(4, long(ps.size()));
  DOUBLES_EQUAL(1003.5, ps.stamps_s[3], 1e-9);
  DOUBLES_EQUAL(0.0, ps.profile(2)[0], 0);
  DOUBLES_EQUAL(0.223404, ps.profile(2)[1], 1e-7);
  const Reader rd = [](const std::string& p, std::string& e) {
    io::ProfileSet s;
    return io::read_profiles_txt(p, 8, s, e);
  };
  // One range missing on the third profile (file line 4).
  std::string text = profiles_text(4, 8);
  std::string bad = text;
  const std::size_t l4 = bad.find("1002.5");
  bad.erase(bad.find(" 0.223404", l4), 9);
  check_bad_text(dir, "p.txt", bad, rd, "p.txt:4: expected 9 values (a timestamp and 8 ranges), got 8");
  check_bad_text(dir, "p.txt", "1 0 0 0 0 0 0 0 -0.1\n", rd, "p.txt:1: range 7 is '-0.1'");
  check_bad_text(dir, "p.txt", "1 0 0 0 0 0 0 0 nan\n", rd, "range 7 is 'nan'");
  check_bad_text(dir, "p.txt", "2 0 0 0 0 0 0 0 0\n1 0 0 0 0 0 0 0 0\n", rd, "p.txt:2: timestamp 1.000000 is not after");
  check_bad_files(dir, "p.txt", rd, "1004.8 0.22 ");
  check_truncations(dir, "cut.txt", text, rd, false);
  CHECK_FALSE(io::read_profiles_txt(path, 1, ps, err));
}

TEST(FormatsText, RealTrajectoryAndPoses) {
  const std::string tum = edgefuse_test::require_data("tum_fr1_xyz_37");
  if (tum.empty()) return;
  std::vector<io::StampedPose> gt;
  std::string err;
  CHECK_TEXT(io::read_tum_trajectory(tum + "/groundtruth.txt", gt, err), err.c_str());
  LONGS_EQUAL(3000, long(gt.size()));
  DOUBLES_EQUAL(1.3563, gt[0].T.t.x(), 1e-6);
  const io::StampedPose* p = io::find_nearest(gt, 1305031102.160407);
  CHECK(p && std::fabs(p->stamp_s - 1305031102.160407) < 0.01);

  const std::string seven = edgefuse_test::require_data("7scenes_redkitchen_300");
  Pose T;
  CHECK_TEXT(io::read_pose_matrix_txt(seven + "/frame-000000.pose.txt", T, err), err.c_str());
  DOUBLES_EQUAL(-0.34045634, T.t.x(), 1e-6);
  DOUBLES_EQUAL(0.9610498, T.R(1, 1), 1e-6);
}
