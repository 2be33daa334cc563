// Pose-link framing (docs/PROTOCOL.md): frame = COBS(payload || CRC-32(payload) little-endian)
// followed by one 0x00 delimiter. The same bytes go over serial and TCP (a stream of frames) and
// UDP (one frame per datagram). The stream decoder resynchronises at the next 0x00 after any
// corruption and counts what it threw away. No OS, no heap: buffers are members or caller-owned.
#pragma once

#include <cstddef>
#include <cstdint>

#include "edgefuse/link/cobs.hpp"

namespace edgefuse::link {

constexpr size_t kCrcBytes = 4;

//! Largest frame (delimiter included) for a payload of `n` bytes.
constexpr size_t max_frame_size(size_t n) { return cobs_max_encoded_size(n + kCrcBytes) + 1; }

//! Frames a payload.
//! \param payload  message bytes (protobuf)
//! \param len      their number
//! \param scratch  work buffer of at least len + 4 bytes (payload and CRC before stuffing)
//! \param scratch_cap its capacity
//! \param out      destination of the frame
//! \param cap      its capacity (max_frame_size(len) always suffices)
//! \return the frame length including the trailing 0x00, or 0 if a buffer is too small
size_t frame_encode(const uint8_t* payload, size_t len, uint8_t* scratch, size_t scratch_cap, uint8_t* out,
                    size_t cap);

//! Counters of a stream decoder (what a link's quality report shows).
struct DecoderStats {
  uint32_t frames = 0;       //!< frames with a good CRC
  uint32_t crc_errors = 0;   //!< frames whose CRC did not match
  uint32_t cobs_errors = 0;  //!< blocks that were not valid COBS or too short to hold a CRC
  uint32_t overruns = 0;     //!< frames longer than the buffer (discarded up to the next 0x00)
};

//! Byte-at-a-time frame decoder over a caller-owned buffer.
class StreamDecoder {
 public:
  //! \param buf  buffer for one encoded frame (without delimiter); max_frame_size(payload) bytes
  //! \param cap  its size
  StreamDecoder(uint8_t* buf, size_t cap) : buf_(buf), cap_(cap) {}

  //! Feeds one received byte.
  //! \param b the byte
  //! \return true when it completed a frame with a good CRC: payload()/payload_size() hold it
  //!         until the next push()
  bool push(uint8_t b);

  const uint8_t* payload() const { return buf_; }
  size_t payload_size() const { return payload_len_; }
  const DecoderStats& stats() const { return stats_; }
  //! Drops a partly received frame (e.g. after reconnecting).
  void reset() {
    len_ = 0;
    dropping_ = false;
  }

 private:
  uint8_t* buf_;
  size_t cap_;
  size_t len_ = 0;
  size_t payload_len_ = 0;
  bool dropping_ = false;  // an overrun: ignore bytes up to the next delimiter
  DecoderStats stats_;
};

//! A decoder with its buffer inside (capacity in the type, as etl::vector).
template <size_t MaxPayload>
class StaticStreamDecoder : public StreamDecoder {
 public:
  StaticStreamDecoder() : StreamDecoder(storage_, sizeof(storage_)) {}
  StaticStreamDecoder(const StaticStreamDecoder&) = delete;
  StaticStreamDecoder& operator=(const StaticStreamDecoder&) = delete;

 private:
  uint8_t storage_[max_frame_size(MaxPayload)];
};

//! Checks one complete frame (e.g. a UDP datagram), with or without its trailing 0x00.
//! \param frame  received bytes; decoded in place
//! \param len    their number
//! \param payload_len  set to the payload length on success
//! \return true if the COBS block is valid and the CRC matches; the payload starts at frame
bool frame_decode_inplace(uint8_t* frame, size_t len, size_t& payload_len);

}  // namespace edgefuse::link
