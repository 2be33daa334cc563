#include "edgefuse/link/messages.hpp"

#include <pb_decode.h>
#include <pb_encode.h>

#include "edgefuse/board_config.hpp"

namespace edgefuse::link {

static_assert(kMaxObjects == 32, "edgefuse_link.options sets max_count:32 for LocalizationResult.objects");

// Every board's result must fit one message: a board may hold fewer objects, never more.
constexpr bool all_boards_fit() {
  for (int i = 0; i < kBoardCount; ++i)
    if (kBoards[i].objects_max > static_cast<int>(kMaxObjects)) return false;
  return true;
}
static_assert(all_boards_fit(), "a board's capacity.objects_max exceeds the link's max_count (edgefuse_link.options)");

namespace {

edgefuse_link_Vec3 vec3(const Vec3f& v) {
  edgefuse_link_Vec3 o = edgefuse_link_Vec3_init_zero;
  o.x = v.x();
  o.y = v.y();
  o.z = v.z();
  return o;
}

}  // namespace

Message make_result(uint32_t seq, uint64_t stamp_us) {
  Message m = edgefuse_link_Message_init_zero;
  m.which_body = edgefuse_link_Message_result_tag;
  m.body.result.seq = seq;
  m.body.result.stamp_us = stamp_us;
  m.body.result.status = edgefuse_link_ResultStatus_RESULT_OK;
  return m;
}

Message make_heartbeat(uint32_t seq, uint64_t stamp_us) {
  Message m = edgefuse_link_Message_init_zero;
  m.which_body = edgefuse_link_Message_heartbeat_tag;
  m.body.heartbeat.seq = seq;
  m.body.heartbeat.stamp_us = stamp_us;
  m.body.heartbeat.protocol_version = edgefuse_link_ProtocolVersion_PROTOCOL_VERSION_CURRENT;
  return m;
}

bool add_object(LocalizationResult& r, uint32_t id, const Pose& T_world_object, float score, const Vec3f& grasp_m,
                const Vec3f& approach) {
  if (r.objects_count >= kMaxObjects) return false;
  ObjectPose& o = r.objects[r.objects_count++];
  o = edgefuse_link_ObjectPose_init_zero;
  o.id = id;
  o.has_position_m = true;
  o.position_m = vec3(T_world_object.t);
  const Eigen::Quaternionf q = T_world_object.quaternion();
  o.has_orientation = true;
  o.orientation.x = q.x();
  o.orientation.y = q.y();
  o.orientation.z = q.z();
  o.orientation.w = q.w();
  o.score = score;
  o.has_grasp_point_m = true;
  o.grasp_point_m = vec3(grasp_m);
  o.has_approach = true;
  o.approach = vec3(approach);
  return true;
}

Pose object_pose(const ObjectPose& o) {
  // A missing orientation (all zero) decodes as identity rather than NaN.
  if (o.orientation.w == 0 && o.orientation.x == 0 && o.orientation.y == 0 && o.orientation.z == 0)
    return Pose::from_tq(o.position_m.x, o.position_m.y, o.position_m.z, 0, 0, 0, 1);
  return Pose::from_tq(o.position_m.x, o.position_m.y, o.position_m.z, o.orientation.x, o.orientation.y,
                       o.orientation.z, o.orientation.w);
}

bool encode_message(const Message& m, uint8_t* out, size_t cap, size_t& len) {
  pb_ostream_t s = pb_ostream_from_buffer(out, cap);
  if (!pb_encode(&s, edgefuse_link_Message_fields, &m)) return false;
  len = s.bytes_written;
  return true;
}

bool decode_message(const uint8_t* in, size_t len, Message& m) {
  m = edgefuse_link_Message_init_zero;
  pb_istream_t s = pb_istream_from_buffer(in, len);
  return pb_decode(&s, edgefuse_link_Message_fields, &m);
}

const uint8_t* FrameWriter::encode(const Message& m, size_t& len) {
  size_t n = 0;
  if (!encode_message(m, payload_, sizeof(payload_), n)) return nullptr;
  len = frame_encode(payload_, n, scratch_, sizeof(scratch_), frame_, sizeof(frame_));
  return len ? frame_ : nullptr;
}

}  // namespace edgefuse::link
