// `edgefuse calibrate --store DIR` (the calibrated mounting goes into the calibration store):
// store_calibrated_pair() puts T_A_B into the two-slot store, keeps what the newest slot already
// holds (other pairs, intrinsic overrides, hand-eye, bin pose), alternates slots with increasing
// sequence numbers, replaces an existing pair instead of adding a second one, survives one corrupt
// slot, and refuses to overwrite a store whose slots are all corrupt (leaving the files as they were).
#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>

#include "calib_store_io.hpp"
#include "edgefuse/hal/platform/config/calib_file_store.hpp"

#include <CppUTest/TestHarness.h>

using namespace edgefuse;
using namespace edgefuse::runtime;

namespace {

std::string fresh_dir(const char* name) {
  char tmpl[] = "/tmp/edgefuse_calib_store_XXXXXX";
  const char* d = mkdtemp(tmpl);
  CHECK(d != nullptr);
  return std::string(d) + "/" + name;
}

std::string read_all(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

Pose mounting(float x) {
  return Pose::from_tq(x, 0.0073f, -0.0006f, -0.0134f, -0.0187f, 0.0190f, 0.99955f);
}

void check_pair(const CalibrationData& d, const char* from, const char* to, const Pose& T) {
  const SensorPair* p = calib_find_pair(d, from, to);
  CHECK(p != nullptr);
  const Pose got = Pose::from_tq(p->T_from_to.tq[0], p->T_from_to.tq[1], p->T_from_to.tq[2], p->T_from_to.tq[3],
                                 p->T_from_to.tq[4], p->T_from_to.tq[5], p->T_from_to.tq[6]);
  CHECK((got.t - T.t).norm() < 1e-7f);
  CHECK((T.inverse() * got).angle_rad() < 1e-5f);
}

}  // namespace

TEST_GROUP(FusionCalibStore){};

TEST(FusionCalibStore, NewStoreThenSecondSaveKeepsOtherEntries) {
  const std::string dir = fresh_dir("store");
  std::string msg, err;
  CHECK_TRUE_TEXT(cli::store_calibrated_pair(dir, "xtion", "tof", mounting(0.0573f), msg, err), err.c_str());
  CHECK(msg.find("calib_a.bin (seq 1; new store)") != std::string::npos);

  // edgefused's console adds a hand-eye pose and an intrinsic override to the same store.
  hal::CalibFileStore store(dir);
  CalibrationData d;
  hal::CalibLoadReport rep;
  CHECK(store.load(d, rep));
  d.T_flange_rig.tq[2] = 0.125f;
  d.intrinsic_count = 1;
  std::strcpy(d.intrinsics[0].sensor, "tof");
  d.intrinsics[0].fx = 80.5f;
  CalibPose other;
  other.tq[0] = 0.3f;
  CHECK(calib_set_pair(d, "rig", "laser", other));
  CHECK(store.save(d, err));  // seq 2 in calib_b.bin

  // Re-calibrating the pair replaces it and keeps the rest.
  CHECK_TRUE_TEXT(cli::store_calibrated_pair(dir, "xtion", "tof", mounting(0.0575f), msg, err), err.c_str());
  CHECK(msg.find("calib_a.bin (seq 3; kept the other entries of seq 2)") != std::string::npos);
  CalibrationData back;
  CHECK(store.load(back, rep));
  LONGS_EQUAL(3, int(rep.seq));
  LONGS_EQUAL(2, back.pair_count);
  check_pair(back, "xtion", "tof", mounting(0.0575f));
  CHECK(calib_find_pair(back, "rig", "laser") != nullptr);
  DOUBLES_EQUAL(0.3, back.pairs[1].T_from_to.tq[0], 1e-7);
  DOUBLES_EQUAL(0.125, back.T_flange_rig.tq[2], 1e-7);
  LONGS_EQUAL(1, back.intrinsic_count);
  DOUBLES_EQUAL(80.5, back.intrinsics[0].fx, 1e-6);
}

TEST(FusionCalibStore, OneCorruptSlotIsTolerated) {
  const std::string dir = fresh_dir("store");
  std::string msg, err;
  CHECK(cli::store_calibrated_pair(dir, "xtion", "tof", mounting(0.05f), msg, err));
  CHECK(cli::store_calibrated_pair(dir, "xtion", "laser", mounting(0.06f), msg, err));  // seq 2, slot b
  // A power cut damaged slot b: the newest valid slot is a (seq 1), and the next save replaces b.
  std::ofstream(dir + "/calib_b.bin", std::ios::binary | std::ios::trunc) << "torn";
  CHECK_TRUE_TEXT(cli::store_calibrated_pair(dir, "xtion", "tof", mounting(0.07f), msg, err), err.c_str());
  CHECK(msg.find("calib_b.bin (seq 2; kept the other entries of seq 1)") != std::string::npos);
  hal::CalibFileStore store(dir);
  CalibrationData back;
  hal::CalibLoadReport rep;
  CHECK(store.load(back, rep));
  LONGS_EQUAL(1, back.pair_count);  // the xtion/laser pair was only in the torn slot
  check_pair(back, "xtion", "tof", mounting(0.07f));
}

TEST(FusionCalibStore, AllSlotsCorruptIsRefusedAndUntouched) {
  const std::string dir = fresh_dir("store");
  std::string msg, err;
  CHECK(cli::store_calibrated_pair(dir, "xtion", "tof", mounting(0.05f), msg, err));
  std::ofstream(dir + "/calib_a.bin", std::ios::binary | std::ios::trunc) << "garbage";
  std::ofstream(dir + "/calib_b.bin", std::ios::binary | std::ios::trunc) << "garbage, too";
  CHECK_FALSE(cli::store_calibrated_pair(dir, "xtion", "tof", mounting(0.06f), msg, err));
  CHECK(err.find(dir + "/calib_a.bin") != std::string::npos);
  CHECK(err.find("not overwriting") != std::string::npos);
  STRCMP_EQUAL("garbage", read_all(dir + "/calib_a.bin").c_str());
  STRCMP_EQUAL("garbage, too", read_all(dir + "/calib_b.bin").c_str());
}

TEST(FusionCalibStore, BadNamesAndFullTableAreRefused) {
  const std::string dir = fresh_dir("store");
  std::string msg, err;
  CHECK_FALSE(cli::store_calibrated_pair(dir, "a_sensor_name_too_long", "tof", mounting(0.05f), msg, err));
  CHECK(err.find("longer than 15") != std::string::npos);
  for (int i = 0; i < kCalibPairsMax; ++i)
    CHECK(cli::store_calibrated_pair(dir, "xtion", ("s" + std::to_string(i)).c_str(), mounting(0.05f), msg, err));
  CHECK_FALSE(cli::store_calibrated_pair(dir, "xtion", "one_more", mounting(0.05f), msg, err));
  CHECK(err.find("table is full") != std::string::npos);
}
