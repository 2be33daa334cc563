// Pose-link messages: the nanopb structs generated from include/edgefuse/proto/edgefuse_link.proto
// and their encoding into frames. Static sizes only: a LocalizationResult holds at most
// kMaxObjects poses (edgefuse_link.options), so encoding needs no heap.
#pragma once

#include <cstddef>
#include <cstdint>

#include "edgefuse/link/frame.hpp"
#include "edgefuse/math/pose.hpp"
#include "edgefuse/proto/edgefuse_link.pb.h"

namespace edgefuse::link {

using Message = edgefuse_link_Message;
using LocalizationResult = edgefuse_link_LocalizationResult;
using Heartbeat = edgefuse_link_Heartbeat;
using ObjectPose = edgefuse_link_ObjectPose;

constexpr size_t kMaxPayload = edgefuse_link_Message_size;
constexpr size_t kMaxFrame = max_frame_size(kMaxPayload);
constexpr size_t kMaxObjects = sizeof(LocalizationResult::objects) / sizeof(ObjectPose);

//! An empty result message (status OK, no objects).
Message make_result(uint32_t seq, uint64_t stamp_us);
//! A heartbeat message with the current protocol version.
Message make_heartbeat(uint32_t seq, uint64_t stamp_us);

//! Appends an object to a result.
//! \param r         the result
//! \param id        object (model) id
//! \param T_world_object object-to-world pose (metres)
//! \param score     0..1
//! \param grasp_m   grasp point in the world frame
//! \param approach  unit approach direction in the world frame
//! \return false if the result is full (kMaxObjects)
bool add_object(LocalizationResult& r, uint32_t id, const Pose& T_world_object, float score, const Vec3f& grasp_m,
                const Vec3f& approach);

//! The object-to-world pose of a received object.
Pose object_pose(const ObjectPose& o);

//! Protobuf-encodes a message.
//! \param m    the message
//! \param out  destination
//! \param cap  its capacity (kMaxPayload always suffices)
//! \param len  set to the encoded length
bool encode_message(const Message& m, uint8_t* out, size_t cap, size_t& len);

//! Decodes a protobuf payload into `m` (fails on malformed input or more than kMaxObjects).
//! \param in   payload bytes
//! \param len  their number
//! \param m    the decoded message
bool decode_message(const uint8_t* in, size_t len, Message& m);

//! Encodes messages into frames from buffers inside the object (one per sender; not shared
//! between threads).
class FrameWriter {
 public:
  //! \param m    message to send
  //! \param len  set to the frame length (delimiter included)
  //! \return the frame, valid until the next call, or nullptr if encoding failed
  const uint8_t* encode(const Message& m, size_t& len);

 private:
  uint8_t payload_[kMaxPayload];
  uint8_t scratch_[kMaxPayload + kCrcBytes];
  uint8_t frame_[kMaxFrame];
};

}  // namespace edgefuse::link
