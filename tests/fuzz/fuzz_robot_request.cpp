// Fuzz target for the robot's protobuf requests (src/link/robot_codec.cpp) and the session that
// answers them (src/robot/robot_session.cpp) on the real runtime with the exact-pose pipeline:
// any byte stream a robot controller, a cable fault or a confused client sends on the link.
// The input is a byte stream; a 0xFF 0xFF pair advances the clock by the next byte's number of
// 20 ms ticks (so captures, detects and their replies happen in between).
// Invariants:
//   - no crash or sanitizer report, whatever the bytes;
//   - an unreadable request carries its reason; a decoded pose is finite and orthonormal;
//   - every reply encodes into a frame that decodes again to a reply with the request's id;
//   - the session's counters account for every request: bad + unknown <= requests.
#include <cstdint>
#include <cstring>
#include <new>

#include "../firmware/exact_pose_pipeline.hpp"
#include "edgefuse/link/publisher.hpp"
#include "edgefuse/link/robot_codec.hpp"
#include "edgefuse/robot/robot_session.hpp"
#include "fuzz_check.hpp"

namespace {

using namespace edgefuse;

class NullPublisher : public runtime::Publisher {
 public:
  void publish(const runtime::ResultInfo&) override {}
  void publish(const runtime::HeartbeatInfo&) override {}
};

class NullStorage : public runtime::CalibrationStorage {
 public:
  bool save(const runtime::CalibrationData&, char*, size_t) override { return true; }
  bool load(runtime::CalibrationData&, char*, size_t) override { return false; }
};

class CheckedReplies : public robot::ReplySink {
 public:
  void reply(int, const robot::Reply& r) override {
    size_t n = 0;
    const uint8_t* f = writer_.encode(r, n);
    FUZZ_CHECK(f != nullptr && n <= sizeof copy_, "a reply does not encode");
    std::memcpy(copy_, f, n);
    size_t len = 0;
    FUZZ_CHECK(link::frame_decode_inplace(copy_, n, len), "a reply frame does not decode");
    FUZZ_CHECK(link::decode_message(copy_, len, msg_) && msg_.which_body == edgefuse_link_Message_reply_tag &&
                   msg_.body.reply.id == r.id,
               "a reply frame does not decode to the reply");
  }

 private:
  link::ReplyWriter writer_;
  uint8_t copy_[link::kMaxFrame];
  link::Message msg_;
};

class Forward : public link::RequestHandler {
 public:
  robot::RobotSession* session = nullptr;
  uint64_t now_us = 0;
  void request(int client, const robot::Request& r) override {
    FUZZ_CHECK(r.command != robot::Command::kNone || r.error != nullptr, "an unreadable request without a reason");
    if (r.has_pose) {
      const Pose& p = r.T_base_flange;
      FUZZ_CHECK(p.t.allFinite() && (p.R * p.R.transpose() - Mat3f::Identity()).norm() < 1e-4f,
                 "a decoded flange pose is not finite and orthonormal");
    }
    session->handle(client, r, now_us);
  }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  // Fresh state for each input (static storage: the objects are large).
  static edgefuse_test::ExactPosePipeline* pipeline = nullptr;
  static runtime::ParamStore* params = nullptr;
  static runtime::Runtime* rt = nullptr;
  static robot::RobotSession* session = nullptr;
  static link::RequestStreams* streams = nullptr;
  static NullPublisher publisher;
  static NullStorage storage;
  static CheckedReplies replies;
  static Forward forward;
  alignas(edgefuse_test::ExactPosePipeline) static unsigned char pipeline_mem[sizeof(edgefuse_test::ExactPosePipeline)];
  alignas(runtime::ParamStore) static unsigned char params_mem[sizeof(runtime::ParamStore)];
  alignas(runtime::Runtime) static unsigned char rt_mem[sizeof(runtime::Runtime)];
  alignas(robot::RobotSession) static unsigned char session_mem[sizeof(robot::RobotSession)];
  alignas(link::RequestStreams) static unsigned char streams_mem[sizeof(link::RequestStreams)];
  if (session != nullptr) {
    streams->~RequestStreams();
    session->~RobotSession();
    rt->~Runtime();
    params->~ParamStore();
    pipeline->~ExactPosePipeline();
  }
  pipeline = new (pipeline_mem) edgefuse_test::ExactPosePipeline();
  params = new (params_mem) runtime::ParamStore();
  rt = new (rt_mem) runtime::Runtime(*pipeline, *params, storage, publisher);
  session = new (session_mem) robot::RobotSession(*rt, *pipeline, replies);
  streams = new (streams_mem) link::RequestStreams();
  rt->set_result_listener(session);
  forward.session = session;

  uint64_t now_us = 1000000;
  size_t start = 0;
  for (size_t i = 0; i < size; ++i) {
    if (i + 2 < size && data[i] == 0xFF && data[i + 1] == 0xFF) {
      streams->feed(int(data[start] % link::RequestStreams::kStreams), data + start, i - start, forward);
      for (int k = 0; k < data[i + 2]; ++k) {
        now_us += 20000;
        rt->tick(now_us);
        session->tick(now_us);
      }
      forward.now_us = now_us;
      i += 2;
      start = i + 1;
    }
  }
  if (start < size) streams->feed(0, data + start, size - start, forward);
  const robot::SessionCounters& c = session->counters();
  FUZZ_CHECK(c.bad_requests + c.unknown_commands <= c.requests, "%u bad + %u unknown of %u requests",
             c.bad_requests, c.unknown_commands, c.requests);
  return 0;
}
