// The runtime's state machine with a fake pipeline: IDLE -> MAPPING (scan start) -> LOCALIZE (on
// command or after the still period) -> REPORT -> back to MAPPING / IDLE; results numbered and
// filtered by localize.min_score, heartbeats at link.heartbeat_ms, commands refused in the wrong
// state, and no heap allocation in steady state.
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "edgefuse/link/publisher.hpp"
#include "edgefuse/runtime/runtime.hpp"
#include "fake_pipeline.hpp"

#include <CppUTest/TestHarness.h>

using namespace edgefuse;
using namespace edgefuse::runtime;

namespace {

class FakePipeline : public edgefuse_test::FakePipeline {
 public:
  uint64_t still_since = 0;
  void fill_result(LocalizationOutcome& out) override {
    out.stamp_us = now - 1000;
    ObjectResult o;
    o.id = 1;
    o.score = 0.9f;
    o.approach = Vec3f::UnitZ();
    out.add(o);
    o.id = 2;
    o.score = 0.3f;
    out.add(o);
  }
  // xtion -> tof "calibrates" to a fixed mounting; anything else is refused.
  bool calibrate_pair(const char* from, const char* to, PairCalibrationReport& out, const char** why) override {
    if (std::string(from) != "xtion" || std::string(to) != "tof") {
      *why = "scene is a single plane";
      return false;
    }
    out.T_from_to.tq[0] = 0.057f;
    return true;
  }
  int calibrations_seen = 0;
  void calibration_changed(const CalibrationData&) override { ++calibrations_seen; }
  PipelineStats stats() const override {
    PipelineStats s;
    s.frames = frames;
    s.still_since_us = still_since;
    return s;
  }
};

class FakeStorage : public CalibrationStorage {
 public:
  int saves = 0;
  bool save(const CalibrationData&, char*, size_t) override {
    ++saves;
    return true;
  }
  bool load(CalibrationData&, char*, size_t) override { return true; }
};

class Capture : public link::FrameSink {
 public:
  std::vector<link::Message> got;
  bool record = true;
  void send(const uint8_t* frame, size_t len) override {
    if (!record) return;
    std::vector<uint8_t> f(frame, frame + len);
    size_t n = 0;
    CHECK(link::frame_decode_inplace(f.data(), f.size(), n));
    link::Message m;
    CHECK(link::decode_message(f.data(), n, m));
    got.push_back(m);
  }
  int count(pb_size_t tag) const {
    int k = 0;
    for (const auto& m : got) k += m.which_body == tag;
    return k;
  }
};

struct Rig {
  FakePipeline pipe;
  ParamStore params;
  FakeStorage storage;
  Capture link;
  link::LinkPublisher publisher{link};
  Runtime rt{pipe, params, storage, publisher};
  uint64_t t = 1000000;
  void run_ms(int ms) {
    for (int i = 0; i < ms; i += 10) rt.tick(t += 10000);
  }
};

}  // namespace

TEST_GROUP(RuntimeStates){};

TEST(RuntimeStates, CommandDrivenCycle) {
  static Rig r;  // static (one per test): the runtime holds a whole message buffer
  r.run_ms(100);
  CHECK(r.rt.state() == RuntimeState::kIdle);
  CHECK(r.rt.localize().code == ConsoleError::kWrongState);  // empty map
  CHECK(r.rt.scan(true).code == ConsoleError::kOk);
  CHECK(r.rt.state() == RuntimeState::kMapping);
  r.run_ms(100);
  CHECK(r.rt.localize().code == ConsoleError::kOk);
  CHECK(r.rt.state() == RuntimeState::kLocalize);
  CHECK(r.rt.localize().code == ConsoleError::kWrongState);   // already localising
  CHECK(r.rt.map_reset().code == ConsoleError::kWrongState);  // not while localising
  r.run_ms(100);
  CHECK(r.rt.state() == RuntimeState::kMapping);  // reported, back to mapping
  CHECK_EQUAL(1, r.link.count(edgefuse_link_Message_result_tag));
  const link::Message* res = nullptr;
  for (const auto& m : r.link.got)
    if (m.which_body == edgefuse_link_Message_result_tag) res = &m;
  CHECK_EQUAL(0u, res->body.result.seq);
  CHECK_EQUAL(1u, res->body.result.objects_count);  // the 0.3 object is below min_score 0.5
  CHECK_EQUAL(1u, res->body.result.objects[0].id);
  // Stop scanning during localisation: the report ends in IDLE.
  CHECK(r.rt.localize().code == ConsoleError::kOk);
  CHECK(r.rt.scan(false).code == ConsoleError::kOk);
  r.run_ms(100);
  CHECK(r.rt.state() == RuntimeState::kIdle);
  CHECK_FALSE(r.pipe.mapping);
  CHECK_EQUAL(2, r.link.count(edgefuse_link_Message_result_tag));
  CHECK_EQUAL(2u, r.rt.results_sent());
}

TEST(RuntimeStates, HeartbeatsFollowTheParameter) {
  static Rig r;
  r.run_ms(2000);  // 1000 ms default: t=0 and about every second
  const int n = r.link.count(edgefuse_link_Message_heartbeat_tag);
  CHECK(n >= 2 && n <= 3);
  char err[100];
  CHECK(r.params.set(kLinkHeartbeatMs, "100", err, sizeof(err)));
  r.rt.param_changed(kLinkHeartbeatMs);
  r.run_ms(1000);
  const int m = r.link.count(edgefuse_link_Message_heartbeat_tag) - n;
  CHECK(m >= 9 && m <= 11);
  CHECK_EQUAL(1u, r.link.got.back().body.heartbeat.protocol_version);
}

// A heartbeat that falls due in the tick that collects the result must not overwrite it: with one
// shared message buffer (a union body) the result went out with no objects (seen once in the
// edgefused end-to-end test: 4 objects logged, none at the listener).
TEST(RuntimeStates, ResultSurvivesAHeartbeatInTheCollectingTick) {
  static Rig r;
  char err[100];
  CHECK(r.params.set(kLinkHeartbeatMs, "100", err, sizeof(err)));
  r.rt.param_changed(kLinkHeartbeatMs);
  CHECK(r.rt.scan(true).code == ConsoleError::kOk);
  for (int i = 0; i < 3; ++i) r.rt.tick(r.t += 100000);  // every tick sends a heartbeat
  CHECK(r.rt.localize().code == ConsoleError::kOk);
  const int beats = r.link.count(edgefuse_link_Message_heartbeat_tag);
  r.rt.tick(r.t += 100000);  // the result is collected (done after 50 ms) and a heartbeat is due
  CHECK(r.rt.state() == RuntimeState::kReport);
  CHECK_EQUAL(beats + 1, r.link.count(edgefuse_link_Message_heartbeat_tag));
  r.rt.tick(r.t += 100000);  // reported
  CHECK_EQUAL(1, r.link.count(edgefuse_link_Message_result_tag));
  for (const auto& m : r.link.got)
    if (m.which_body == edgefuse_link_Message_result_tag) {
      CHECK_EQUAL(1u, m.body.result.objects_count);
      CHECK_EQUAL(1u, m.body.result.objects[0].id);
      CHECK(m.body.result.status == edgefuse_link_ResultStatus_RESULT_OK);
    }
}

TEST(RuntimeStates, StillPeriodTriggersOneLocalisation) {
  static Rig r;
  char err[100];
  CHECK(r.params.set(kLocalizeStillPeriodS, "0.5", err, sizeof(err)));
  r.rt.scan(true);
  r.run_ms(300);
  r.pipe.still_since = r.t;  // the rig stops
  r.run_ms(400);
  CHECK_EQUAL(0, r.link.count(edgefuse_link_Message_result_tag));
  r.run_ms(300);
  CHECK_EQUAL(1, r.link.count(edgefuse_link_Message_result_tag));
  r.run_ms(2000);  // still: no second trigger
  CHECK_EQUAL(1, r.link.count(edgefuse_link_Message_result_tag));
  r.pipe.still_since = 0;  // moves ...
  r.run_ms(100);
  r.pipe.still_since = r.t;  // ... and stops again
  r.run_ms(700);
  CHECK_EQUAL(2, r.link.count(edgefuse_link_Message_result_tag));
}

TEST(RuntimeStates, CalibSetNamesSensorsFlangeAndBin) {
  static Rig r;
  const float tq[7] = {0.1f, 0.2f, 0.3f, 0, 0, 0, 1};
  CHECK(r.rt.calib_set("xtion", tq).code == ConsoleError::kOk);
  CHECK(r.rt.calib_set("flange", tq).code == ConsoleError::kOk);
  CHECK(r.rt.calib_set("bin", tq).code == ConsoleError::kOk);
  CHECK(r.rt.calib_set("nosuch", tq).code == ConsoleError::kNotFound);
  const float k[4] = {500, 501, 320, 240};
  CHECK(r.rt.calib_intrinsics("xtion", k).code == ConsoleError::kOk);
  CHECK(r.rt.calib_intrinsics("xtion", k).code == ConsoleError::kOk);  // replaces, does not add
  CHECK(r.rt.calib_intrinsics("nosuch", k).code == ConsoleError::kNotFound);
  CHECK_EQUAL(1, r.rt.calibration().intrinsic_count);
  CHECK_EQUAL(501.0f, r.rt.calibration().intrinsics[0].fy);
  const CalibrationData& d = r.rt.calibration();
  CHECK(calib_find_pair(d, "rig", "xtion") != nullptr);
  CHECK_EQUAL(0.2f, d.T_flange_rig.tq[1]);
  CHECK_EQUAL(0.3f, d.T_world_bin.tq[2]);
  CHECK(r.rt.calib_reset().code == ConsoleError::kOk);
  CHECK_EQUAL(0, r.rt.calibration().pair_count);
}

class TextSink : public ConsoleWriter {
 public:
  std::string text;
  void write(const char* s, size_t n) override { text.append(s, n); }
};

// calib fuse: the pipeline's result goes into the calibration as the pair (from, to), is shown
// with its uncertainty and saved; a refusal is an ERR with the pipeline's reason and changes nothing.
TEST(RuntimeStates, CalibFuseStoresAndSavesThePair) {
  static Rig r;
  TextSink out;
  const CmdResult bad = r.rt.calib_fuse("xtion", "laser", out);
  CHECK(bad.code == ConsoleError::kFailed);
  STRCMP_EQUAL("scene is a single plane", bad.message);
  CHECK_EQUAL(0, r.rt.calibration().pair_count);
  CHECK_EQUAL(0, r.storage.saves);
  CHECK(r.rt.calib_fuse("xtion", "tof", out).code == ConsoleError::kOk);
  const SensorPair* p = calib_find_pair(r.rt.calibration(), "xtion", "tof");
  CHECK(p != nullptr);
  CHECK_EQUAL(0.057f, p->T_from_to.tq[0]);
  CHECK_EQUAL(1, r.storage.saves);
  CHECK(r.pipe.calibrations_seen >= 1);
  CHECK(out.text.find("T_xtion_tof: t 0.0570") != std::string::npos);
  CHECK(out.text.find("uncertainty (1 sigma, tof frame)") != std::string::npos);
}

TEST(RuntimeStates, SteadyStateDoesNotAllocate) {
  static Rig r;
  r.link.record = false;
  r.rt.scan(true);
  r.run_ms(100);
  edgefuse_test::alloc_count_start();
  for (int k = 0; k < 20; ++k) {
    r.rt.localize();
    r.run_ms(200);
  }
  CHECK_EQUAL(0L, edgefuse_test::alloc_count());
  CHECK_EQUAL(20u, r.rt.results_sent());
}
