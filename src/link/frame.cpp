#include "edgefuse/link/frame.hpp"

#include "edgefuse/link/crc32.hpp"

namespace edgefuse::link {
namespace {

// Checks COBS and CRC of a block without delimiter; decodes in place.
// \return 1 good, 0 bad CRC, -1 bad COBS / too short
int check_block(uint8_t* block, size_t len, size_t& payload_len) {
  const long n = cobs_decode(block, len, block);
  if (n < static_cast<long>(kCrcBytes)) return -1;
  const size_t body = static_cast<size_t>(n) - kCrcBytes;
  const uint32_t want = uint32_t(block[body]) | (uint32_t(block[body + 1]) << 8) | (uint32_t(block[body + 2]) << 16) |
                        (uint32_t(block[body + 3]) << 24);
  if (crc32(block, body) != want) return 0;
  payload_len = body;
  return 1;
}

}  // namespace

size_t frame_encode(const uint8_t* payload, size_t len, uint8_t* scratch, size_t scratch_cap, uint8_t* out,
                    size_t cap) {
  if (scratch_cap < len + kCrcBytes || cap < max_frame_size(len)) return 0;
  for (size_t i = 0; i < len; ++i) scratch[i] = payload[i];
  const uint32_t c = crc32(payload, len);
  scratch[len] = uint8_t(c);
  scratch[len + 1] = uint8_t(c >> 8);
  scratch[len + 2] = uint8_t(c >> 16);
  scratch[len + 3] = uint8_t(c >> 24);
  const size_t n = cobs_encode(scratch, len + kCrcBytes, out, cap - 1);
  if (n == 0) return 0;
  out[n] = 0;
  return n + 1;
}

bool StreamDecoder::push(uint8_t b) {
  if (b != 0) {
    if (dropping_) return false;
    if (len_ == cap_) {
      ++stats_.overruns;
      dropping_ = true;
      len_ = 0;
      return false;
    }
    buf_[len_++] = b;
    return false;
  }
  // Delimiter: a frame ends (empty frames, e.g. a sender's resync zero, are ignored).
  const size_t len = len_;
  len_ = 0;
  if (dropping_) {
    dropping_ = false;
    return false;
  }
  if (len == 0) return false;
  const int r = check_block(buf_, len, payload_len_);
  if (r > 0) {
    ++stats_.frames;
    return true;
  }
  if (r == 0)
    ++stats_.crc_errors;
  else
    ++stats_.cobs_errors;
  return false;
}

bool frame_decode_inplace(uint8_t* frame, size_t len, size_t& payload_len) {
  if (len > 0 && frame[len - 1] == 0) --len;
  for (size_t i = 0; i < len; ++i)
    if (frame[i] == 0) return false;
  return check_block(frame, len, payload_len) > 0;
}

}  // namespace edgefuse::link
