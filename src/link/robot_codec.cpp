#include "edgefuse/link/robot_codec.hpp"

#include "edgefuse/link/publisher.hpp"

#include <cmath>
#include <cstdio>

namespace edgefuse::link {
namespace {

static_assert(sizeof(RobotReply::message) == robot::kReplyMessageMax + 1,
              "edgefuse_link.options: RobotReply.message max_size matches robot::kReplyMessageMax");

edgefuse_link_RobotPose wire_pose(const Pose& p) {
  edgefuse_link_RobotPose o = edgefuse_link_RobotPose_init_zero;
  const Eigen::Quaternionf q = p.quaternion();
  o.has_position_m = o.has_orientation = true;
  o.position_m.x = p.t.x();
  o.position_m.y = p.t.y();
  o.position_m.z = p.t.z();
  o.orientation.x = q.x();
  o.orientation.y = q.y();
  o.orientation.z = q.z();
  o.orientation.w = q.w();
  return o;
}

// \return nullptr, or why the pose is not usable
const char* plain_pose(const edgefuse_link_RobotPose& w, Pose& p) {
  const edgefuse_link_Quaternion& q = w.orientation;
  const edgefuse_link_Vec3& t = w.position_m;
  if (!w.has_orientation) return "T_base_flange has no orientation";
  const float v[7] = {t.x, t.y, t.z, q.x, q.y, q.z, q.w};
  for (float x : v)
    if (!std::isfinite(x)) return "T_base_flange holds a value that is not a finite number";
  const float norm = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
  if (std::fabs(norm - 1.0f) > 0.01f) return "T_base_flange's quaternion is not unit length";
  p = Pose::from_tq(t.x, t.y, t.z, q.x, q.y, q.z, q.w);
  return nullptr;
}

robot::Command plain_command(edgefuse_link_RobotCommand c) {
  const int v = int(c);
  if (v >= int(robot::Command::kCapture) && v <= int(robot::Command::kCalibrationGet)) return robot::Command(v);
  return v == 0 ? robot::Command::kNone : robot::Command::kUnknown;
}

}  // namespace

void decode_request(const uint8_t* payload, size_t len, robot::Request& out) {
  out = robot::Request();
  static Message m;  // 2.8 kB: not on the service loop's stack; one decoder runs at a time
  if (!decode_message(payload, len, m)) {
    out.error = "not a protobuf Message";
    return;
  }
  if (m.which_body != edgefuse_link_Message_request_tag) {
    out.error = "not a request (Message.request expected)";
    return;
  }
  const RobotRequest& r = m.body.request;
  out.id = r.id;
  out.command = plain_command(r.command);
  if (out.command == robot::Command::kNone) out.error = "no command";
  out.stamp_us = r.stamp_us;
  out.picked = r.picked;
  if (r.has_T_base_flange) {
    if (const char* why = plain_pose(r.T_base_flange, out.T_base_flange)) {
      out.command = robot::Command::kNone;
      out.error = why;
      return;
    }
    out.has_pose = true;
  }
}

void request_message(const robot::Request& r, Message& m) {
  m = edgefuse_link_Message_init_zero;
  m.which_body = edgefuse_link_Message_request_tag;
  RobotRequest& o = m.body.request;
  o.id = r.id;
  o.command = edgefuse_link_RobotCommand(r.command == robot::Command::kUnknown ? 99 : int(r.command));
  o.stamp_us = r.stamp_us;
  o.picked = r.picked;
  o.has_T_base_flange = r.has_pose;
  if (r.has_pose) o.T_base_flange = wire_pose(r.T_base_flange);
}

void reply_message(const robot::Reply& r, Message& m) {
  m = edgefuse_link_Message_init_zero;
  m.which_body = edgefuse_link_Message_reply_tag;
  RobotReply& o = m.body.reply;
  o.id = r.id;
  o.command = edgefuse_link_RobotCommand(r.command == robot::Command::kUnknown ? 0 : int(r.command));
  o.status = edgefuse_link_ReplyStatus(int(r.status));
  o.count = r.count;
  o.left = r.left;
  if (r.has_object) {
    LocalizationResult one = edgefuse_link_LocalizationResult_init_zero;
    add_object(one, r.object.id, r.object.T_world_object, r.object.score, r.object.grasp_m, r.object.approach);
    o.has_object = true;
    o.object = one.objects[0];
    o.has_grasp = true;
    o.grasp = wire_pose(r.T_base_grasp);
  }
  if (r.has_hand_eye) {
    o.has_hand_eye = true;
    o.hand_eye = wire_pose(r.T_flange_camera);
  }
  o.residual_mm = r.residual_mm;
  o.residual_deg = r.residual_deg;
  o.state = to_wire(r.state);
  o.tracking = to_wire(r.tracking);
  o.stations = r.stations;
  std::snprintf(o.message, sizeof(o.message), "%s", r.message);
}

void RequestStreams::feed(int client, const uint8_t* data, size_t n, RequestHandler& h) {
  StreamDecoder& d = decoders_[client];
  for (size_t i = 0; i < n; ++i) {
    const DecoderStats before = d.stats();
    if (d.push(data[i])) {
      decode_request(d.payload(), d.payload_size(), request_);
      h.request(client, request_);
      continue;
    }
    const DecoderStats& after = d.stats();
    const char* why = after.crc_errors != before.crc_errors     ? "frame failed its CRC"
                      : after.cobs_errors != before.cobs_errors ? "frame is not valid COBS"
                      : after.overruns != before.overruns       ? "frame longer than the largest message"
                                                                : nullptr;
    if (why == nullptr) continue;
    request_ = robot::Request();
    request_.error = why;
    h.request(client, request_);
  }
}

const uint8_t* ReplyWriter::encode(const robot::Reply& r, size_t& len) {
  reply_message(r, msg_);
  return writer_.encode(msg_, len);
}

}  // namespace edgefuse::link
