#include "edgefuse/link/publisher.hpp"

namespace edgefuse::link {

static_assert(int(kMaxObjects) == runtime::kResultObjectsMax,
              "a runtime result holds as many objects as the link's message");

edgefuse_link_RuntimeState to_wire(runtime::RuntimeState s) {
  switch (s) {
    case runtime::RuntimeState::kIdle: return edgefuse_link_RuntimeState_STATE_IDLE;
    case runtime::RuntimeState::kMapping: return edgefuse_link_RuntimeState_STATE_MAPPING;
    case runtime::RuntimeState::kLocalize: return edgefuse_link_RuntimeState_STATE_LOCALIZE;
    case runtime::RuntimeState::kReport: return edgefuse_link_RuntimeState_STATE_REPORT;
  }
  return edgefuse_link_RuntimeState_STATE_ERROR;
}

edgefuse_link_TrackingState to_wire(runtime::TrackingState t) {
  switch (t) {
    case runtime::TrackingState::kOff: return edgefuse_link_TrackingState_TRACKING_OFF;
    case runtime::TrackingState::kOk: return edgefuse_link_TrackingState_TRACKING_OK;
    case runtime::TrackingState::kDegraded: return edgefuse_link_TrackingState_TRACKING_DEGRADED;
    case runtime::TrackingState::kLost: return edgefuse_link_TrackingState_TRACKING_LOST;
  }
  return edgefuse_link_TrackingState_TRACKING_OFF;
}

edgefuse_link_ResultStatus to_wire(runtime::ResultStatus s) {
  switch (s) {
    case runtime::ResultStatus::kOk: return edgefuse_link_ResultStatus_RESULT_OK;
    case runtime::ResultStatus::kNoObjects: return edgefuse_link_ResultStatus_RESULT_NO_OBJECTS;
    case runtime::ResultStatus::kFailed: return edgefuse_link_ResultStatus_RESULT_FAILED;
  }
  return edgefuse_link_ResultStatus_RESULT_FAILED;
}

void LinkPublisher::send(const Message& m) {
  size_t n = 0;
  const uint8_t* f = writer_.encode(m, n);
  if (f != nullptr) sink_.send(f, n);
}

void LinkPublisher::publish(const runtime::ResultInfo& r) {
  msg_ = make_result(r.seq, r.stamp_us);
  LocalizationResult& out = msg_.body.result;
  out.status = to_wire(r.status);
  for (int i = 0; i < r.count; ++i) {
    const runtime::ObjectResult& o = r.objects[i];
    if (!add_object(out, o.id, o.T_world_object, o.score, o.grasp_m, o.approach)) break;
  }
  send(msg_);
}

void LinkPublisher::publish(const runtime::HeartbeatInfo& h) {
  msg_ = make_heartbeat(h.seq, h.stamp_us);
  Heartbeat& b = msg_.body.heartbeat;
  b.state = to_wire(h.state);
  b.tracking = to_wire(h.tracking);
  b.fps = h.fps;
  b.frames = h.frames;
  b.drops = h.drops;
  b.results = h.results;
  b.uptime_s = h.uptime_s;
  send(msg_);
}

}  // namespace edgefuse::link
