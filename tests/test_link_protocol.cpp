// Pose link: CRC-32 against zlib, COBS edge cases, message round trip through nanopb and the
// framing, resynchronisation of the stream decoder after corrupted bytes (CRC errors counted),
// UDP datagrams, and zero heap allocations while encoding and decoding.
#include <zlib.h>

#include <cstring>
#include <vector>

#include "alloc_counter.hpp"
#include "edgefuse/link/crc32.hpp"
#include "edgefuse/link/messages.hpp"

#include <CppUTest/TestHarness.h>

using namespace edgefuse;
using namespace edgefuse::link;

namespace {

Message sample_result(uint32_t seq, int objects) {
  Message m = make_result(seq, 1000000ull * seq + 17);
  for (int i = 0; i < objects; ++i) {
    const Pose p = Pose::from_tq(0.1f * i, -0.2f, 0.7f + 0.01f * i, 0.1f, 0.2f, 0.3f, 0.9f);
    add_object(m.body.result, uint32_t(i + 1), p, 0.5f + 0.01f * i, p.t + Vec3f(0, 0, 0.01f), Vec3f(0, 0, 1));
  }
  return m;
}

// Frames `count` results into one byte stream.
std::vector<uint8_t> stream_of(int count, int objects, std::vector<size_t>* starts = nullptr) {
  static FrameWriter w;
  std::vector<uint8_t> s;
  for (int i = 0; i < count; ++i) {
    size_t n = 0;
    const uint8_t* f = w.encode(sample_result(uint32_t(i), objects), n);
    CHECK(f != nullptr);
    if (starts) starts->push_back(s.size());
    s.insert(s.end(), f, f + n);
  }
  return s;
}

// Index of the first COBS data byte (not a code byte) at or after start + offset in the frame at start.
size_t data_byte_at_or_after(const std::vector<uint8_t>& s, size_t start, size_t offset) {
  size_t next_code = start;
  for (size_t i = start;; ++i) {
    if (i == next_code) {
      next_code = i + s[i];
      continue;
    }
    if (i >= start + offset) return i;
  }
}

std::vector<uint32_t> decode_seqs(const std::vector<uint8_t>& s, StreamDecoder& d) {
  std::vector<uint32_t> seqs;
  Message m;
  for (uint8_t b : s)
    if (d.push(b)) {
      CHECK(decode_message(d.payload(), d.payload_size(), m));
      CHECK_EQUAL(edgefuse_link_Message_result_tag, m.which_body);
      seqs.push_back(m.body.result.seq);
    }
  return seqs;
}

}  // namespace

TEST_GROUP(LinkProtocol){};

TEST(LinkProtocol, Crc32MatchesZlib) {
  const char* check = "123456789";
  CHECK_EQUAL(0xCBF43926u, crc32(reinterpret_cast<const uint8_t*>(check), 9));
  std::vector<uint8_t> data(1000);
  for (size_t i = 0; i < data.size(); ++i) data[i] = uint8_t(i * 31 + 7);
  CHECK_EQUAL(uint32_t(::crc32(0, data.data(), uInt(data.size()))), crc32(data.data(), data.size()));
  // Continuation equals one pass.
  CHECK_EQUAL(crc32(data.data(), data.size()), crc32(data.data() + 400, 600, crc32(data.data(), 400)));
}

TEST(LinkProtocol, CobsRoundTripEdgeCases) {
  const std::vector<std::vector<uint8_t>> cases = {
      {}, {0}, {0, 0}, {1}, {1, 0, 2}, std::vector<uint8_t>(253, 5), std::vector<uint8_t>(254, 5),
      std::vector<uint8_t>(255, 5), std::vector<uint8_t>(600, 9)};
  for (std::vector<uint8_t> in : cases) {
    if (in.size() == 600) in[300] = 0;
    std::vector<uint8_t> enc(cobs_max_encoded_size(in.size()));
    const size_t n = cobs_encode(in.data(), in.size(), enc.data(), enc.size());
    CHECK(n > 0 && n <= enc.size());
    for (size_t i = 0; i < n; ++i) CHECK(enc[i] != 0);
    std::vector<uint8_t> dec(n);
    const long m = cobs_decode(enc.data(), n, dec.data());
    CHECK_EQUAL(long(in.size()), m);
    CHECK(std::equal(in.begin(), in.end(), dec.begin()));
  }
  // Known vector (Wikipedia): 11 22 00 33 -> 03 11 22 02 33.
  const uint8_t in[] = {0x11, 0x22, 0x00, 0x33};
  uint8_t out[8];
  CHECK_EQUAL(5u, cobs_encode(in, 4, out, sizeof(out)));
  const uint8_t want[] = {0x03, 0x11, 0x22, 0x02, 0x33};
  MEMCMP_EQUAL(want, out, 5);
  // A code byte running past the end is malformed.
  const uint8_t bad[] = {0x05, 0x11};
  uint8_t tmp[4];
  CHECK_EQUAL(-1L, cobs_decode(bad, 2, tmp));
}

TEST(LinkProtocol, ResultRoundTripKeepsEveryField) {
  FrameWriter w;
  const Message m = sample_result(42, int(kMaxObjects));
  size_t n = 0;
  const uint8_t* f = w.encode(m, n);
  CHECK(f != nullptr);
  CHECK(n <= kMaxFrame);
  CHECK_EQUAL(0, f[n - 1]);
  for (size_t i = 0; i + 1 < n; ++i) CHECK(f[i] != 0);

  StaticStreamDecoder<kMaxPayload> d;
  int got = 0;
  Message r;
  for (size_t i = 0; i < n; ++i)
    if (d.push(f[i])) {
      ++got;
      CHECK(decode_message(d.payload(), d.payload_size(), r));
    }
  CHECK_EQUAL(1, got);
  CHECK_EQUAL(edgefuse_link_Message_result_tag, r.which_body);
  const LocalizationResult& a = m.body.result;
  const LocalizationResult& b = r.body.result;
  CHECK_EQUAL(a.seq, b.seq);
  CHECK(a.stamp_us == b.stamp_us);
  CHECK_EQUAL(int(kMaxObjects), int(b.objects_count));
  for (unsigned i = 0; i < b.objects_count; ++i) {
    const ObjectPose& x = a.objects[i];
    const ObjectPose& y = b.objects[i];
    CHECK_EQUAL(x.id, y.id);
    // Floats travel as IEEE fixed32: bit-exact.
    CHECK(std::memcmp(&x.position_m, &y.position_m, sizeof(x.position_m)) == 0);
    CHECK(std::memcmp(&x.orientation, &y.orientation, sizeof(x.orientation)) == 0);
    CHECK(std::memcmp(&x.grasp_point_m, &y.grasp_point_m, sizeof(x.grasp_point_m)) == 0);
    CHECK(std::memcmp(&x.approach, &y.approach, sizeof(x.approach)) == 0);
    CHECK_EQUAL(x.score, y.score);
    const Pose p = object_pose(y);
    const Pose q = Pose::from_tq(0.1f * i, -0.2f, 0.7f + 0.01f * i, 0.1f, 0.2f, 0.3f, 0.9f);
    CHECK((p.R - q.R).norm() < 1e-5f);
    CHECK((p.t - q.t).norm() < 1e-6f);
  }
  // A result is full at kMaxObjects.
  Message full = sample_result(1, int(kMaxObjects));
  CHECK_FALSE(add_object(full.body.result, 99, Pose{}, 1, Vec3f::Zero(), Vec3f::UnitZ()));
}

TEST(LinkProtocol, HeartbeatRoundTrip) {
  FrameWriter w;
  Message m = make_heartbeat(7, 123456789012ull);
  m.body.heartbeat.state = edgefuse_link_RuntimeState_STATE_MAPPING;
  m.body.heartbeat.fps = 29.5f;
  m.body.heartbeat.drops = 3;
  size_t n = 0;
  uint8_t* f = const_cast<uint8_t*>(w.encode(m, n));
  std::vector<uint8_t> copy(f, f + n);
  size_t len = 0;
  CHECK(frame_decode_inplace(copy.data(), copy.size(), len));
  Message r;
  CHECK(decode_message(copy.data(), len, r));
  CHECK_EQUAL(edgefuse_link_Message_heartbeat_tag, r.which_body);
  CHECK_EQUAL(7u, r.body.heartbeat.seq);
  CHECK(r.body.heartbeat.stamp_us == 123456789012ull);
  CHECK_EQUAL(1u, r.body.heartbeat.protocol_version);
  CHECK_EQUAL(edgefuse_link_RuntimeState_STATE_MAPPING, r.body.heartbeat.state);
  CHECK_EQUAL(3u, r.body.heartbeat.drops);
}

TEST(LinkProtocol, ResynchronisesAfterCorruptedBytesAndCountsCrcErrors) {
  std::vector<size_t> starts;
  std::vector<uint8_t> s = stream_of(40, 3, &starts);
  // Corrupt one byte (never into 0x00) in frames 5, 17 and 30, flip a byte to 0x00 inside frame 22
  // (splits it in two), and put line noise in front of the stream.
  const int corrupt[] = {5, 17, 30};
  for (int k : corrupt) {
    // A data byte (not a COBS code byte), so the block stays valid COBS and only the CRC fails.
    uint8_t& b = s[data_byte_at_or_after(s, starts[size_t(k)], 20)];
    b = uint8_t(b ^ 0x5A) ? uint8_t(b ^ 0x5A) : 0x01;
  }
  s[starts[22] + 10] = 0;
  const uint8_t noise[] = {0xFF, 0x13, 0x37, 0x42};
  s.insert(s.begin(), noise, noise + sizeof(noise));

  StaticStreamDecoder<kMaxPayload> d;
  const std::vector<uint32_t> seqs = decode_seqs(s, d);
  // Lost: 5, 17, 30 (bad CRC), 22 (split in two) and 0 (the noise has no delimiter of its own, so
  // it is glued to frame 0). Every other frame arrives, in order.
  CHECK_EQUAL(40u - 5u, seqs.size());
  for (uint32_t q : seqs) CHECK(q != 0 && q != 5 && q != 17 && q != 22 && q != 30);
  for (size_t i = 1; i < seqs.size(); ++i) CHECK(seqs[i] > seqs[i - 1]);
  const DecoderStats& st = d.stats();
  CHECK_EQUAL(35u, st.frames);
  CHECK_EQUAL(0u, st.overruns);
  // Frames 5, 17, 30 fail the CRC; frame 0 behind the noise and the two halves of 22 fail the CRC
  // or the COBS check.
  CHECK(st.crc_errors >= 3);
  CHECK_EQUAL(6u, st.crc_errors + st.cobs_errors);
}

TEST(LinkProtocol, NoiseBeforeADelimiterCostsNothing) {
  std::vector<uint8_t> s = stream_of(5, 2);
  const uint8_t noise[] = {0xFF, 0x13, 0x37, 0x00};
  s.insert(s.begin(), noise, noise + sizeof(noise));
  StaticStreamDecoder<kMaxPayload> d;
  CHECK_EQUAL(5u, decode_seqs(s, d).size());
  CHECK_EQUAL(1u, d.stats().crc_errors + d.stats().cobs_errors);
}

TEST(LinkProtocol, OverlongFrameIsDroppedUpToTheNextDelimiter) {
  std::vector<uint8_t> s(kMaxFrame * 3, 0x11);  // no delimiter for far longer than any frame
  s.push_back(0);
  const std::vector<uint8_t> good = stream_of(3, 1);
  s.insert(s.end(), good.begin(), good.end());
  StaticStreamDecoder<kMaxPayload> d;
  CHECK_EQUAL(3u, decode_seqs(s, d).size());
  CHECK_EQUAL(1u, d.stats().overruns);
}

TEST(LinkProtocol, TruncatedAndGarbagePayloadsAreRejected) {
  size_t n = 0;
  FrameWriter w;
  const uint8_t* f = w.encode(sample_result(3, 4), n);
  std::vector<uint8_t> copy(f, f + n);
  // A datagram cut short fails the CRC.
  size_t len = 0;
  CHECK_FALSE(frame_decode_inplace(copy.data(), copy.size() / 2, len));
  // A protobuf payload that claims more than kMaxObjects objects is refused by the decoder.
  uint8_t big[kMaxPayload * 2];
  size_t o = 0;
  big[o++] = 0x0A;  // Message.result, length-delimited
  const size_t len_at = o;
  o += 2;           // two-byte varint length, filled below
  for (size_t i = 0; i < kMaxObjects + 1; ++i) {
    big[o++] = 0x22;  // objects
    big[o++] = 0x02;
    big[o++] = 0x08;  // id = 1
    big[o++] = 0x01;
  }
  const size_t body = o - len_at - 2;
  big[len_at] = uint8_t(0x80 | (body & 0x7F));
  big[len_at + 1] = uint8_t(body >> 7);
  Message m;
  CHECK_FALSE(decode_message(big, o, m));
  const uint8_t junk[] = {0xFF, 0xFF, 0xFF, 0xFF, 0xFF};
  CHECK_FALSE(decode_message(junk, sizeof(junk), m));
}

TEST(LinkProtocol, EncodingAndDecodingDoNotAllocate) {
  static FrameWriter w;
  static StaticStreamDecoder<kMaxPayload> d;
  static Message m;
  static Message r;
  m = sample_result(1, 10);
  edgefuse_test::alloc_count_start();
  int got = 0;
  for (int k = 0; k < 100; ++k) {
    m.body.result.seq = uint32_t(k);
    size_t n = 0;
    const uint8_t* f = w.encode(m, n);
    for (size_t i = 0; i < n; ++i)
      if (d.push(f[i]) && decode_message(d.payload(), d.payload_size(), r)) ++got;
  }
  CHECK_EQUAL(0L, edgefuse_test::alloc_count());
  CHECK_EQUAL(100, got);
}
