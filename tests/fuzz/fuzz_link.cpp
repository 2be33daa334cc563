// Fuzz target for what a pose-link receiver parses (the robot side and `tools/listen.py`'s C++
// peer): the stream decoder, COBS, the CRC frame check and the nanopb message decoder.
// Invariants:
//   - no crash or sanitizer report on any byte stream;
//   - the decoder's counters account for every delimiter, and a completed frame fits its buffer;
//   - a decoded message re-encodes, and the re-encoding decodes to the same bytes (round trip);
//   - any payload up to kMaxPayload survives frame_encode -> stream decoder unchanged.
#include <cstdint>
#include <cstring>

#include "edgefuse/link/cobs.hpp"
#include "edgefuse/link/frame.hpp"
#include "edgefuse/link/messages.hpp"
#include "fuzz_check.hpp"

namespace {

using namespace edgefuse::link;

void check_round_trip(const uint8_t* payload, size_t len) {
  static Message m, again;
  static uint8_t first[kMaxPayload], second[kMaxPayload];
  if (!decode_message(payload, len, m)) return;
  size_t n1 = 0, n2 = 0;
  FUZZ_CHECK(encode_message(m, first, sizeof first, n1), "a decoded message (%zu bytes) does not encode", len);
  FUZZ_CHECK(decode_message(first, n1, again), "a re-encoded message does not decode");
  FUZZ_CHECK(encode_message(again, second, sizeof second, n2), "a twice-decoded message does not encode");
  FUZZ_CHECK(n1 == n2 && !std::memcmp(first, second, n1), "encode(decode(x)) is not stable (%zu vs %zu bytes)", n1,
             n2);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  // 1. The input as a received byte stream.
  StaticStreamDecoder<kMaxPayload> rx;  // fresh counters for each input
  size_t delimiters = 0;
  for (size_t i = 0; i < size; ++i) {
    delimiters += data[i] == 0;
    if (rx.push(data[i])) {
      FUZZ_CHECK(rx.payload_size() <= kMaxFrame, "a %zu-byte payload from a %zu-byte buffer", rx.payload_size(),
                 kMaxFrame);
      check_round_trip(rx.payload(), rx.payload_size());
    }
  }
  const DecoderStats& st = rx.stats();
  // Every delimiter ends at most one frame, good or bad; an overrun is counted when the buffer
  // fills, so the last one may still wait for its delimiter.
  FUZZ_CHECK(st.frames + st.crc_errors + st.cobs_errors + st.overruns <= delimiters + (st.overruns > 0 ? 1 : 0),
             "%u frames + %u CRC + %u COBS errors + %u overruns from %zu delimiters", st.frames, st.crc_errors,
             st.cobs_errors, st.overruns, delimiters);

  // 2. The input as one datagram (UDP), decoded in place.
  static uint8_t datagram[4 * kMaxFrame];
  if (size <= sizeof datagram) {
    std::memcpy(datagram, data, size);
    size_t payload_len = 0;
    if (frame_decode_inplace(datagram, size, payload_len)) {
      FUZZ_CHECK(payload_len + kCrcBytes <= size, "payload of %zu bytes from a %zu-byte datagram", payload_len, size);
      check_round_trip(datagram, payload_len);
    }
    // COBS alone: decoding never writes more than it reads.
    static uint8_t out[4 * kMaxFrame];
    const long n = cobs_decode(data, size, out);
    FUZZ_CHECK(n < 0 || size_t(n) <= size, "COBS decoded %ld bytes from %zu", n, size);
  }

  // 3. The input as a payload to send: framing it and streaming the frame back gives it unchanged.
  if (size <= kMaxPayload) {
    static uint8_t scratch[kMaxPayload + kCrcBytes], frame[kMaxFrame];
    const size_t n = frame_encode(data, size, scratch, sizeof scratch, frame, sizeof frame);
    FUZZ_CHECK(n > 0 && n <= max_frame_size(size) && frame[n - 1] == 0, "framing %zu bytes gave %zu", size, n);
    StaticStreamDecoder<kMaxPayload> loop;
    bool got = false;
    for (size_t i = 0; i < n; ++i) got = loop.push(frame[i]);
    FUZZ_CHECK(got && loop.payload_size() == size && !std::memcmp(loop.payload(), data, size),
               "a framed %zu-byte payload did not come back unchanged", size);
  }
  return 0;
}
