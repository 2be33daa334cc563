// The robot session against the real runtime and a fake pipeline: capture -> detect -> next ->
// pick results in picking order, the asynchronous detect and its status poll, a detect waiting for
// the first frames, failures and bad requests answered and counted, the streamed flange poses in
// their stamped history, hand-eye stations solved and saved, and no heap per request.
#include <cmath>
#include <vector>

#include "alloc_counter.hpp"
#include "edgefuse/robot/robot_session.hpp"
#include "fake_pipeline.hpp"

#include <CppUTest/TestHarness.h>

using namespace edgefuse;
using namespace edgefuse::robot;

namespace {

class FakePipeline : public edgefuse_test::FakePipeline {
 public:
  bool fail_next = false;
  int objects = 2;
  bool have_rig_pose = false;
  Pose rig_pose_now;
  void fill_result(runtime::LocalizationOutcome& out) override {
    out.failed = fail_next;
    for (int i = 0; i < objects; ++i) {
      runtime::ObjectResult o;
      o.id = uint32_t(i + 1);
      o.score = 0.9f - 0.1f * float(i);
      o.T_world_object = Pose::from_tq(0.4f + 0.01f * float(i), 0, 0.03f, 0, 0, 0, 1);
      out.add(o);
    }
  }
  bool calibrate_pair(const char*, const char*, runtime::PairCalibrationReport&, const char** why) override {
    *why = "no";
    return false;
  }
  bool rig_pose(Pose& T, uint64_t& stamp_us) const override {
    T = rig_pose_now;
    stamp_us = now;
    return have_rig_pose;
  }
  runtime::PipelineStats stats() const override { return {}; }
};

class NullPublisher : public runtime::Publisher {
 public:
  void publish(const runtime::ResultInfo&) override {}
  void publish(const runtime::HeartbeatInfo&) override {}
};

class MemoryStorage : public runtime::CalibrationStorage {
 public:
  int saves = 0;
  runtime::CalibrationData saved;
  bool save(const runtime::CalibrationData& d, char*, size_t) override {
    saved = d;
    ++saves;
    return true;
  }
  bool load(runtime::CalibrationData&, char*, size_t) override { return false; }
};

// Keeps the last replies (capacity fixed, so that the alloc test measures the session alone).
class Replies : public ReplySink {
 public:
  static constexpr int kMax = 64;
  Reply r[kMax];
  int client[kMax] = {};
  int n = 0;
  void reply(int c, const Reply& x) override {
    if (n == kMax) n = 0;
    client[n] = c;
    r[n++] = x;
  }
  const Reply& last() const { return r[n - 1]; }
};

struct Cell {
  FakePipeline pipeline;
  runtime::ParamStore params;
  MemoryStorage storage;
  NullPublisher publisher;
  runtime::Runtime rt{pipeline, params, storage, publisher};
  Replies out;
  RobotSession session{rt, pipeline, out};
  uint64_t now = 1000000;
  uint32_t next_id = 1;

  Cell() { rt.set_result_listener(&session); }
  void tick(int times = 1, uint64_t step_us = 10000) {
    for (int i = 0; i < times; ++i) {
      now += step_us;
      rt.tick(now);
      session.tick(now);
    }
  }
  Request req(Command c) {
    Request r;
    r.id = next_id++;
    r.command = c;
    return r;
  }
  Request posed(Command c, const Pose& p) {
    Request r = req(c);
    r.has_pose = true;
    r.T_base_flange = p;
    return r;
  }
  const Reply& ask(const Request& r, int client = 0) {
    session.handle(client, r, now);
    return out.last();
  }
  // CAPTURE, a few frames, DETECT, and the ticks until its reply.
  void capture_and_detect() {
    ask(posed(Command::kCapture, Pose()));
    tick(3);
    const int before = out.n;
    session.handle(0, req(Command::kDetect), now);
    for (int i = 0; i < 20 && out.n == before; ++i) tick();
  }
};

Pose flange_at(int i) {
  // Stations rotated about two horizontal axes (and a little about z), 0.1 m apart.
  const float a = 0.35f * float(i % 3) - 0.35f, b = 0.3f * float(i / 3) - 0.15f;
  Pose p;
  p.R = (Eigen::AngleAxisf(a, Vec3f::UnitX()) * Eigen::AngleAxisf(b, Vec3f::UnitY()) *
         Eigen::AngleAxisf(0.2f * float(i), Vec3f::UnitZ()))
            .toRotationMatrix();
  p.t = Vec3f(0.4f + 0.05f * float(i), -0.1f + 0.03f * float(i), 0.5f);
  return p;
}

}  // namespace

TEST_GROUP(RobotSession){};

TEST(RobotSession, CaptureDetectNextPickedInPickingOrder) {
  Cell c;
  const Reply& cap = c.ask(c.posed(Command::kCapture, Pose::from_tq(0.1f, 0.2f, 0.3f, 0, 0, 0, 1)));
  CHECK(cap.status == ReplyStatus::kOk);
  CHECK(c.rt.state() == runtime::RuntimeState::kMapping);
  c.tick(3);
  const int before = c.out.n;
  c.session.handle(3, c.req(Command::kDetect), c.now);
  LONGS_EQUAL(before, c.out.n);  // the reply comes when the localisation is done
  c.tick(10);
  LONGS_EQUAL(before + 1, c.out.n);
  CHECK(c.out.last().status == ReplyStatus::kOk);
  LONGS_EQUAL(2, c.out.last().count);
  LONGS_EQUAL(3, c.out.client[c.out.n - 1]);
  LONGS_EQUAL(2, c.out.last().id);  // the detect's id (the capture was 1)

  // NEXT walks the list in picking order; PICKED takes the offered object out.
  const Reply& first = c.ask(c.req(Command::kNext));
  CHECK(first.status == ReplyStatus::kOk && first.has_object);
  LONGS_EQUAL(1, first.object.id);
  LONGS_EQUAL(1, first.left);
  CHECK(first.T_base_grasp.t.isApprox(first.object.T_world_object.t));  // no grasp planner: the object pose
  Request picked = c.req(Command::kPickResult);
  picked.picked = true;
  LONGS_EQUAL(1, c.ask(picked).left);
  const Reply& second = c.ask(c.req(Command::kNext));
  LONGS_EQUAL(2, second.object.id);
  LONGS_EQUAL(0, second.left);
  Request failed = c.req(Command::kPickResult);
  failed.picked = false;
  CHECK(c.ask(failed).status == ReplyStatus::kOk);
  CHECK(c.ask(c.req(Command::kNext)).status == ReplyStatus::kNoObjects);
  LONGS_EQUAL(0, c.session.objects_left());
  // The next detect offers every object again, the failed one included.
  c.capture_and_detect();
  LONGS_EQUAL(2, c.session.objects_left());
  LONGS_EQUAL(1, c.ask(c.req(Command::kNext)).object.id);
}

TEST(RobotSession, NextWithoutPickResultsWalksTheListAndAFailedObjectStaysOut) {
  Cell c;
  c.pipeline.objects = 3;
  c.capture_and_detect();
  LONGS_EQUAL(3, c.out.last().count);
  LONGS_EQUAL(1, c.ask(c.req(Command::kNext)).object.id);
  LONGS_EQUAL(2, c.ask(c.req(Command::kNext)).object.id);
  Request failed = c.req(Command::kPickResult);
  CHECK(c.ask(failed).status == ReplyStatus::kOk);  // object 2 failed
  const Reply& third = c.ask(c.req(Command::kNext));
  LONGS_EQUAL(3, third.object.id);
  LONGS_EQUAL(0, third.left);
  CHECK(c.ask(c.req(Command::kNext)).status == ReplyStatus::kNoObjects);
  // A pick result without an offered object is a bad request, answered and counted.
  CHECK(c.ask(c.req(Command::kPickResult)).status == ReplyStatus::kOk);  // object 3 (offered last)
  const Reply& again = c.ask(c.req(Command::kPickResult));
  CHECK(again.status == ReplyStatus::kBadRequest);
  STRCMP_CONTAINS("NEXT first", again.message);
}

TEST(RobotSession, AsynchronousDetectAndStatusPoll) {
  Cell c;
  CHECK(c.ask(c.req(Command::kDetectStatus)).status == ReplyStatus::kNoObjects);  // no detect yet
  c.ask(c.posed(Command::kCapture, Pose()));
  c.tick(3);
  CHECK(c.ask(c.req(Command::kDetectAsync)).status == ReplyStatus::kOk);
  CHECK(c.ask(c.req(Command::kDetectStatus)).status == ReplyStatus::kRunning);
  CHECK(c.ask(c.req(Command::kNext)).status == ReplyStatus::kBusy);
  c.tick(10);
  const Reply& done = c.ask(c.req(Command::kDetectStatus));
  CHECK(done.status == ReplyStatus::kOk);
  LONGS_EQUAL(2, done.count);
  c.pipeline.objects = 0;
  c.ask(c.req(Command::kDetectAsync));
  c.tick(10);
  CHECK(c.ask(c.req(Command::kDetectStatus)).status == ReplyStatus::kNoObjects);
}

TEST(RobotSession, DetectRightAfterCaptureWaitsForTheFirstFrames) {
  Cell c;
  c.ask(c.posed(Command::kCapture, Pose()));
  const int before = c.out.n;
  c.session.handle(0, c.req(Command::kDetect), c.now);  // the map is still empty
  LONGS_EQUAL(before, c.out.n);
  c.tick(10);
  LONGS_EQUAL(before + 1, c.out.n);
  CHECK(c.out.last().status == ReplyStatus::kOk);
}

TEST(RobotSession, DetectFailuresAreAnswered) {
  Cell c;
  const Reply& idle = c.ask(c.req(Command::kDetect));  // no capture: the map is empty
  CHECK(idle.status == ReplyStatus::kFailed);
  STRCMP_CONTAINS("empty", idle.message);
  const Reply& idle_async = c.ask(c.req(Command::kDetectAsync));
  CHECK(idle_async.status == ReplyStatus::kFailed);
  STRCMP_CONTAINS("empty", idle_async.message);
  CHECK(c.ask(c.req(Command::kDetectStatus)).status == ReplyStatus::kFailed);
  c.pipeline.fail_next = true;
  c.capture_and_detect();
  CHECK(c.out.last().status == ReplyStatus::kFailed);
  // A capture while localising is refused as busy.
  c.pipeline.fail_next = false;
  c.ask(c.req(Command::kDetectAsync));
  CHECK(c.ask(c.posed(Command::kCapture, Pose())).status == ReplyStatus::kBusy);
}

TEST(RobotSession, TwoClientsWaitingForOneDetectBothGetTheReply) {
  Cell c;
  c.ask(c.posed(Command::kCapture, Pose()));
  c.tick(3);
  const int before = c.out.n;
  c.session.handle(1, c.req(Command::kDetect), c.now);
  c.session.handle(2, c.req(Command::kDetect), c.now);
  c.session.handle(5, c.req(Command::kDetect), c.now);
  c.session.client_closed(5);  // gone: no reply for it
  c.tick(10);
  LONGS_EQUAL(before + 2, c.out.n);
  LONGS_EQUAL(1, c.out.client[c.out.n - 2]);
  LONGS_EQUAL(2, c.out.client[c.out.n - 1]);
}

TEST(RobotSession, BadAndUnknownRequestsAreAnsweredAndCounted) {
  Cell c;
  Request garbled;
  garbled.error = "frame failed its CRC";
  const Reply& bad = c.ask(garbled);
  CHECK(bad.status == ReplyStatus::kBadRequest);
  STRCMP_EQUAL("frame failed its CRC", bad.message);
  CHECK(c.ask(c.req(Command::kUnknown)).status == ReplyStatus::kUnknownCommand);
  CHECK(c.ask(c.req(Command::kCapture)).status == ReplyStatus::kBadRequest);  // no flange pose
  CHECK(c.ask(c.req(Command::kPose)).status == ReplyStatus::kBadRequest);
  CHECK(c.ask(c.req(Command::kHandEyeAdd)).status == ReplyStatus::kBadRequest);
  LONGS_EQUAL(4, c.session.counters().bad_requests);
  LONGS_EQUAL(1, c.session.counters().unknown_commands);
  CHECK(c.rt.state() == runtime::RuntimeState::kIdle);  // nothing changed
  const Reply& st = c.ask(c.req(Command::kStatus));
  CHECK(st.status == ReplyStatus::kOk && st.state == runtime::RuntimeState::kIdle);
}

TEST(RobotSession, StreamedPosesGoToTheStampedHistoryWithoutReplies) {
  Cell c;
  const int before = c.out.n;
  for (int i = 0; i < 1000; ++i) {  // 4 s at 250 Hz
    Request r = c.posed(Command::kPose, Pose::from_tq(0.001f * float(i), 0, 0.5f, 0, 0, 0, 1));
    r.stamp_us = 5000000 + uint64_t(i) * 4000;
    c.session.handle(0, r, c.now);
  }
  LONGS_EQUAL(before, c.out.n);
  LONGS_EQUAL(1000, c.session.counters().pose_updates);
  const StampedPoseHistory& h = c.session.flange_poses();
  LONGS_EQUAL(StampedPoseHistory::kCapacity, h.size());
  Pose p;
  CHECK(h.pose_at(5000000 + 999 * 4000 - 2000, p));  // halfway between the last two
  DOUBLES_EQUAL(0.9985, p.t.x(), 1e-5);
  CHECK_FALSE(h.pose_at(5000000, p));  // older than the ring holds
  // A pose older than the newest is refused and counted.
  Request late = c.posed(Command::kPose, Pose());
  late.stamp_us = 5000000;
  c.session.handle(0, late, c.now);
  LONGS_EQUAL(1, c.session.counters().poses_refused);
  // Poses without a stamp that arrive together are stamped in their order, none refused.
  c.now = 9000000;
  for (int i = 0; i < 3; ++i) c.session.handle(0, c.posed(Command::kPose, Pose()), c.now);
  LONGS_EQUAL(1, c.session.counters().poses_refused);
  Pose newest;
  uint64_t newest_us = 0;
  CHECK(h.newest(newest, newest_us));
  CHECK(newest_us == c.now + 2);
}

TEST(RobotSession, HandEyeStationsSolveSaveAndCalibrationGet) {
  Cell c;
  const Pose X = Pose::from_tq(0.03f, -0.02f, 0.11f, 0.0436194f, 0.0f, 0.0f, 0.9990482f);  // T_flange_camera
  const Pose T_map_base = Pose::from_tq(-0.4f, 0.1f, 0.2f, 0.0f, 0.0f, 0.3826834f, 0.9238795f);
  CHECK(c.ask(c.req(Command::kCalibrationGet)).status == ReplyStatus::kNotCalibrated);
  // No camera pose yet (not mapping): refused with the reason.
  const Reply& none = c.ask(c.posed(Command::kHandEyeAdd, flange_at(0)));
  CHECK(none.status == ReplyStatus::kFailed);
  c.pipeline.have_rig_pose = true;
  for (int i = 0; i < 2; ++i) {
    c.pipeline.rig_pose_now = T_map_base * flange_at(i) * X;
    LONGS_EQUAL(i + 1, c.ask(c.posed(Command::kHandEyeAdd, flange_at(i))).count);
  }
  CHECK(c.ask(c.req(Command::kHandEyeSolve)).status == ReplyStatus::kNotCalibrated);  // 2 stations
  CHECK(c.ask(c.req(Command::kHandEyeSave)).status == ReplyStatus::kNotCalibrated);
  for (int i = 2; i < 6; ++i) {
    c.pipeline.rig_pose_now = T_map_base * flange_at(i) * X;
    c.ask(c.posed(Command::kHandEyeAdd, flange_at(i)));
  }
  const Reply& solved = c.ask(c.req(Command::kHandEyeSolve));
  CHECK(solved.status == ReplyStatus::kOk && solved.has_hand_eye);
  CHECK((solved.T_flange_camera.t - X.t).norm() < 1e-4f);
  CHECK((solved.T_flange_camera.inverse() * X).angle_rad() < 1e-3f);
  CHECK(solved.residual_mm < 0.1f);
  CHECK(c.ask(c.req(Command::kHandEyeSave)).status == ReplyStatus::kOk);
  LONGS_EQUAL(1, c.storage.saves);
  DOUBLES_EQUAL(0.11, c.storage.saved.T_flange_rig.tq[2], 1e-4);
  const Reply& got = c.ask(c.req(Command::kCalibrationGet));
  CHECK(got.status == ReplyStatus::kOk);
  CHECK((got.T_flange_camera.t - X.t).norm() < 1e-4f);
  c.ask(c.req(Command::kHandEyeReset));
  LONGS_EQUAL(0, c.session.stations());
}

TEST(RobotSession, NoHeapPerRequest) {
  Cell c;
  c.capture_and_detect();  // warm-up
  edgefuse_test::alloc_count_start();
  for (int k = 0; k < 20; ++k) {
    c.capture_and_detect();
    c.ask(c.req(Command::kNext));
    c.ask(c.req(Command::kPickResult));
    c.ask(c.req(Command::kStatus));
    c.ask(c.req(Command::kDetectStatus));
    c.ask(c.req(Command::kUnknown));
    c.ask(c.posed(Command::kPose, Pose()));
    c.ask(c.req(Command::kHandEyeSolve));
    c.ask(c.req(Command::kCalibrationGet));
  }
  LONGS_EQUAL(0, edgefuse_test::alloc_count());
}
