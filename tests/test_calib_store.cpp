// Calibration store: slot image round trip; every truncation and every single-byte corruption is
// refused; loading takes the newest valid slot and reports a corrupt one; a writer killed (fork +
// SIGKILL) before each step of a save, or failing at each step, never loses the last good
// calibration, and a completed save is what the next start-up loads.
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "edgefuse/hal/platform/config/calib_file_store.hpp"

#include <CppUTest/TestHarness.h>

using namespace edgefuse;
using namespace edgefuse::runtime;
using edgefuse::hal::CalibFileStore;
using edgefuse::hal::CalibLoadReport;
using edgefuse::hal::SaveStep;

namespace {

CalibrationData sample(float x) {
  CalibrationData d;
  CalibPose p;
  p.tq[0] = x;
  p.tq[1] = -0.02f;
  p.tq[2] = 0.005f;
  CHECK(calib_set_pair(d, "xtion", "tof", p));
  p.tq[0] = 2 * x;
  CHECK(calib_set_pair(d, "xtion", "laser", p));
  d.intrinsic_count = 1;
  std::strcpy(d.intrinsics[0].sensor, "tof");
  d.intrinsics[0].fx = 211.5f;
  d.intrinsics[0].fy = 211.25f;
  d.intrinsics[0].cx = 160.0f;
  d.intrinsics[0].cy = 120.5f;
  d.T_flange_rig.tq[2] = 0.12f;
  d.T_world_bin.tq[0] = 0.5f;
  d.T_world_bin.tq[5] = 0.6f;  // qz
  d.T_world_bin.tq[6] = 0.8f;  // qw
  return d;
}

float first_x(const CalibrationData& d) { return d.pairs[0].T_from_to.tq[0]; }

std::string make_dir() {
  char tmpl[] = "/tmp/edgefuse_calib_XXXXXX";
  CHECK(mkdtemp(tmpl) != nullptr);
  return tmpl;
}

void remove_dir(const std::string& dir) {
  for (const char* f : {"/calib_a.bin", "/calib_b.bin", "/calib_a.bin.tmp", "/calib_b.bin.tmp"})
    ::unlink((dir + f).c_str());
  ::rmdir(dir.c_str());
}

std::vector<uint8_t> read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<uint8_t>((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}
void write_bytes(const std::string& path, const std::vector<uint8_t>& b) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(b.data()), std::streamsize(b.size()));
}

struct KillAt {
  SaveStep step;
};
bool kill_hook(SaveStep s, void* ctx) {
  if (s == static_cast<KillAt*>(ctx)->step) ::raise(SIGKILL);  // a power cut right before this step
  return true;
}
bool fail_hook(SaveStep s, void* ctx) { return s != static_cast<KillAt*>(ctx)->step; }

}  // namespace

TEST_GROUP(CalibStore){};

TEST(CalibStore, ImageRoundTrip) {
  const CalibrationData d = sample(0.1f);
  std::vector<uint8_t> img(calib_image_size());
  CHECK_EQUAL(img.size(), calib_encode(d, 7, img.data(), img.size()));
  CalibrationData r;
  uint32_t seq = 0;
  CHECK(SlotStatus::kValid == calib_decode(img.data(), img.size(), r, seq));
  CHECK_EQUAL(7u, seq);
  CHECK_EQUAL(2, r.pair_count);
  STRCMP_EQUAL("laser", r.pairs[1].to);
  CHECK(std::memcmp(&d.pairs[0].T_from_to, &r.pairs[0].T_from_to, sizeof(CalibPose)) == 0);
  CHECK(calib_find_pair(r, "xtion", "tof") != nullptr);
  CHECK(calib_find_pair(r, "tof", "xtion") == nullptr);
  CHECK_EQUAL(211.25f, r.intrinsics[0].fy);
  CHECK_EQUAL(0.12f, r.T_flange_rig.tq[2]);
  CHECK_EQUAL(0.8f, r.T_world_bin.tq[6]);
}

TEST(CalibStore, EveryTruncationAndEveryCorruptByteIsRefused) {
  std::vector<uint8_t> img(calib_image_size());
  calib_encode(sample(0.1f), 3, img.data(), img.size());
  CalibrationData r;
  uint32_t seq;
  for (size_t n = 0; n < img.size(); ++n) CHECK(SlotStatus::kValid != calib_decode(img.data(), n, r, seq));
  for (size_t i = 0; i < img.size(); ++i) {
    for (uint8_t flip : {uint8_t(0x01), uint8_t(0x80), uint8_t(0xFF)}) {
      std::vector<uint8_t> bad = img;
      bad[i] ^= flip;
      CHECK(SlotStatus::kValid != calib_decode(bad.data(), bad.size(), r, seq));
    }
  }
  std::vector<uint8_t> longer = img;
  longer.push_back(0);
  CHECK(SlotStatus::kValid != calib_decode(longer.data(), longer.size(), r, seq));
}

TEST(CalibStore, LoadsTheNewestValidSlotAndReportsACorruptOne) {
  const std::string dir = make_dir();
  CalibFileStore store(dir);
  CalibrationData d;
  CalibLoadReport rep;
  CHECK_FALSE(store.load(d, rep));  // nothing yet: defaults
  CHECK(rep.message.find("no valid slot") != std::string::npos);
  std::string err;
  for (int k = 1; k <= 5; ++k) {
    CHECK_TEXT(store.save(sample(0.01f * k), err), err.c_str());
    CHECK(store.load(d, rep));
    CHECK_EQUAL(uint32_t(k), rep.seq);
    CHECK_EQUAL(0.01f * k, first_x(d));
    CHECK_EQUAL((k - 1) % 2, rep.slot);  // alternates a, b, a, ...
  }
  // Corrupt the newest (seq 5, slot a): seq 4 (slot b) is loaded and the corrupt one reported.
  std::vector<uint8_t> a = read_bytes(store.slot_path(0));
  a[a.size() / 2] ^= 0x10;
  write_bytes(store.slot_path(0), a);
  CHECK(store.load(d, rep));
  CHECK_EQUAL(4u, rep.seq);
  CHECK_EQUAL(0.04f, first_x(d));
  CHECK(rep.status[0] == SlotStatus::kBadCrc);
  CHECK_TEXT(rep.message.find("calib_a.bin is CRC mismatch (corrupt), ignored") != std::string::npos,
             rep.message.c_str());
  // The next save overwrites the corrupt slot, never the good one.
  CHECK(store.save(sample(0.06f), err));
  CHECK(store.load(d, rep));
  CHECK_EQUAL(5u, rep.seq);
  CHECK_EQUAL(0, rep.slot);
  // Truncate slot a, empty slot b: nothing valid, both reported.
  a = read_bytes(store.slot_path(0));
  a.resize(a.size() - 1);
  write_bytes(store.slot_path(0), a);
  write_bytes(store.slot_path(1), {});
  CHECK_FALSE(store.load(d, rep));
  CHECK(rep.status[0] == SlotStatus::kTruncated || rep.status[0] == SlotStatus::kBadContent);
  CHECK(rep.status[1] == SlotStatus::kTruncated);
  remove_dir(dir);
}

TEST(CalibStore, WriterKilledBeforeEachStepNeverLosesTheLastGoodCalibration) {
  for (int step = 0; step < hal::kSaveStepCount; ++step) {
    const std::string dir = make_dir();
    {
      CalibFileStore store(dir);
      std::string err;
      CHECK(store.save(sample(0.01f), err));  // seq 1
      CHECK(store.save(sample(0.02f), err));  // seq 2: the last good one
    }
    const pid_t pid = fork();
    if (pid == 0) {
      CalibFileStore store(dir);
      KillAt k{SaveStep(step)};
      store.set_step_hook(kill_hook, &k);
      std::string err;
      store.save(sample(0.03f), err);
      _exit(0);  // not reached: every step has a hook call
    }
    int status = 0;
    CHECK(waitpid(pid, &status, 0) == pid);
    CHECK_TEXT(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL, hal::to_string(SaveStep(step)));
    CalibFileStore store(dir);
    CalibrationData d;
    CalibLoadReport rep;
    CHECK_TEXT(store.load(d, rep), hal::to_string(SaveStep(step)));
    // Before the rename the old calibration stands; from the rename on the new one is complete.
    if (SaveStep(step) <= SaveStep::kRename) {
      CHECK_EQUAL(2u, rep.seq);
      CHECK_EQUAL(0.02f, first_x(d));
    } else {
      CHECK_EQUAL(3u, rep.seq);
      CHECK_EQUAL(0.03f, first_x(d));
    }
    CHECK(rep.status[0] == SlotStatus::kValid && rep.status[1] == SlotStatus::kValid);
    // And the store keeps working: the next save is seq 3 or 4 and loads.
    std::string err;
    CHECK(store.save(sample(0.04f), err));
    CHECK(store.load(d, rep));
    CHECK_EQUAL(0.04f, first_x(d));
    remove_dir(dir);
  }
}

TEST(CalibStore, FailureAtEachStepReportsItAndKeepsTheOldCalibration) {
  for (int step = 0; step < hal::kSaveStepCount; ++step) {
    const std::string dir = make_dir();
    CalibFileStore store(dir);
    std::string err;
    CHECK(store.save(sample(0.01f), err));
    KillAt k{SaveStep(step)};
    store.set_step_hook(fail_hook, &k);
    CHECK_FALSE(store.save(sample(0.02f), err));
    CHECK_TEXT(err.find(dir) != std::string::npos, err.c_str());  // names the file or folder
    store.set_step_hook(nullptr, nullptr);
    CalibrationData d;
    CalibLoadReport rep;
    CHECK(store.load(d, rep));
    // A failed folder fsync comes after the rename: the new data is there, only not yet durable.
    CHECK_EQUAL(SaveStep(step) == SaveStep::kFsyncDir ? 0.02f : 0.01f, first_x(d));
    remove_dir(dir);
  }
}

TEST(CalibStore, UnwritableFolderIsAnError) {
  CalibFileStore store("/proc/edgefuse-no-such-dir");
  std::string err;
  CHECK_FALSE(store.save(sample(0.01f), err));
  CHECK(err.find("/proc/edgefuse-no-such-dir") != std::string::npos);
}
