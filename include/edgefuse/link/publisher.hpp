// The pose link at the edge: the runtime's heartbeats and results (plain types) encoded into
// protobuf frames (messages.hpp, COBS + CRC framing) and handed to a FrameSink (serial, TCP
// clients, UDP). The only place where runtime types become wire types. No heap.
#pragma once

#include <cstddef>
#include <cstdint>

#include "edgefuse/link/messages.hpp"
#include "edgefuse/runtime/publisher.hpp"

namespace edgefuse::link {

//! Where frames go (serial, TCP clients, UDP): each implementation sends them all.
class FrameSink {
 public:
  virtual ~FrameSink() = default;
  //! \param frame a whole frame (delimiter included)  \param len its length
  virtual void send(const uint8_t* frame, size_t len) = 0;
};

class LinkPublisher final : public runtime::Publisher {
 public:
  //! \param sink where the encoded frames go
  explicit LinkPublisher(FrameSink& sink) : sink_(sink) {}
  void publish(const runtime::ResultInfo& r) override;
  void publish(const runtime::HeartbeatInfo& h) override;

 private:
  void send(const Message& m);

  FrameSink& sink_;
  Message msg_;  // one message at a time: results and heartbeats are encoded and sent at once
  FrameWriter writer_;
};

//! The wire's value of a runtime state / tracking state / result status.
edgefuse_link_RuntimeState to_wire(runtime::RuntimeState s);
edgefuse_link_TrackingState to_wire(runtime::TrackingState t);
edgefuse_link_ResultStatus to_wire(runtime::ResultStatus s);

}  // namespace edgefuse::link
