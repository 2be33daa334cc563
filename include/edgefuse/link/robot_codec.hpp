// The robot's protobuf requests at the link's edge: frames from each client's byte stream (TCP
// client or the serial line) decoded into plain requests (robot/robot_types.hpp), and replies
// encoded into frames for the client that asked. A frame that fails its CRC or COBS check, or an
// unreadable message, becomes a request without a command (Command::kNone, with the reason) so
// that the session answers it with REPLY_BAD_REQUEST and counts it. No OS, no heap.
#pragma once

#include <cstddef>
#include <cstdint>

#include "edgefuse/link/messages.hpp"
#include "edgefuse/robot/robot_types.hpp"

namespace edgefuse::link {

using RobotRequest = edgefuse_link_RobotRequest;
using RobotReply = edgefuse_link_RobotReply;

//! Decodes one frame's payload into a request.
//! \param payload the payload (protobuf Message)  \param len its length
//! \param out the request: Command::kNone with `error` set when the payload is not a readable
//!            request; Command::kUnknown for a command number this board does not know
void decode_request(const uint8_t* payload, size_t len, robot::Request& out);

//! The wire message of a reply. \param r the reply  \param m set to Message.reply
void reply_message(const robot::Reply& r, Message& m);

//! The wire message of a request (robot side, tests). \param r the request  \param m set to Message.request
void request_message(const robot::Request& r, Message& m);

//! Receives the requests a RequestStreams decodes.
class RequestHandler {
 public:
  virtual ~RequestHandler() = default;
  //! \param client the stream it came from  \param r the request (possibly Command::kNone)
  virtual void request(int client, const robot::Request& r) = 0;
};

//! One frame decoder per client stream (kStreams: 8 TCP clients and the serial line).
class RequestStreams {
 public:
  static constexpr int kStreams = 9;
  //! Feeds received bytes; every completed or failed frame reaches `h`.
  //! \param client 0 .. kStreams - 1  \param data bytes  \param n their number  \param h the handler
  void feed(int client, const uint8_t* data, size_t n, RequestHandler& h);
  //! Drops a partly received frame (the client reconnected). \param client its stream
  void reset(int client) { decoders_[client].reset(); }
  //! Counters of one stream's frame decoder. \param client its stream
  const DecoderStats& stats(int client) const { return decoders_[client].stats(); }

 private:
  StaticStreamDecoder<kMaxPayload> decoders_[kStreams];
  robot::Request request_;
};

//! Encodes replies into frames from buffers inside the object.
class ReplyWriter {
 public:
  //! \param r the reply  \param len set to the frame length  \return the frame, or nullptr
  const uint8_t* encode(const robot::Reply& r, size_t& len);

 private:
  Message msg_;
  FrameWriter writer_;
};

}  // namespace edgefuse::link
