#include "edgefuse/runtime/calibration.hpp"

#include <cmath>
#include <cstring>

#include "edgefuse/link/crc32.hpp"

namespace edgefuse::runtime {
namespace {

constexpr uint8_t kMagic[4] = {'E', 'F', 'C', 'A'};
constexpr uint16_t kFormatVersion = 1;

// Little-endian writer/reader: the image is the same on x86-64, aarch64 and armhf.
struct Out {
  uint8_t* p;
  void u32(uint32_t v) {
    for (int i = 0; i < 4; ++i) *p++ = uint8_t(v >> (8 * i));
  }
  void f32(float f) {
    uint32_t v;
    std::memcpy(&v, &f, 4);
    u32(v);
  }
  void name(const char* s) {
    std::memset(p, 0, kSensorNameMax + 1);
    std::memcpy(p, s, std::strlen(s));
    p += kSensorNameMax + 1;
  }
  void pose(const CalibPose& c) {
    for (float f : c.tq) f32(f);
  }
};
struct In {
  const uint8_t* p;
  uint32_t u32() {
    uint32_t v = 0;
    for (int i = 0; i < 4; ++i) v |= uint32_t(*p++) << (8 * i);
    return v;
  }
  float f32() {
    const uint32_t v = u32();
    float f;
    std::memcpy(&f, &v, 4);
    return f;
  }
  bool name(char* s) {
    std::memcpy(s, p, kSensorNameMax + 1);
    p += kSensorNameMax + 1;
    return s[kSensorNameMax] == '\0';
  }
  bool pose(CalibPose& c) {
    for (float& f : c.tq) f = f32();
    for (float f : c.tq)
      if (!std::isfinite(f)) return false;
    const float n = std::sqrt(c.tq[3] * c.tq[3] + c.tq[4] * c.tq[4] + c.tq[5] * c.tq[5] + c.tq[6] * c.tq[6]);
    return std::fabs(n - 1.0f) < 1e-3f;
  }
};

constexpr size_t kPoseBytes = 7 * 4;
constexpr size_t kNameBytes = kSensorNameMax + 1;
constexpr size_t kPayloadBytes = 4 + kCalibPairsMax * (2 * kNameBytes + kPoseBytes) + 4 +
                                 kCalibIntrinsicsMax * (kNameBytes + 4 * 4) + 2 * kPoseBytes;

}  // namespace

bool calib_set_pair(CalibrationData& d, const char* from, const char* to, const CalibPose& T_from_to) {
  if (std::strlen(from) > kSensorNameMax || std::strlen(to) > kSensorNameMax) return false;
  for (int i = 0; i < d.pair_count; ++i)
    if (!std::strcmp(d.pairs[i].from, from) && !std::strcmp(d.pairs[i].to, to)) {
      d.pairs[i].T_from_to = T_from_to;
      return true;
    }
  if (d.pair_count >= kCalibPairsMax) return false;
  SensorPair& p = d.pairs[d.pair_count++];
  p = SensorPair{};
  std::memcpy(p.from, from, std::strlen(from) + 1);
  std::memcpy(p.to, to, std::strlen(to) + 1);
  p.T_from_to = T_from_to;
  return true;
}

const SensorPair* calib_find_pair(const CalibrationData& d, const char* from, const char* to) {
  for (int i = 0; i < d.pair_count; ++i)
    if (!std::strcmp(d.pairs[i].from, from) && !std::strcmp(d.pairs[i].to, to)) return &d.pairs[i];
  return nullptr;
}

size_t calib_image_size() { return kCalibHeaderBytes + kPayloadBytes; }

const char* to_string(SlotStatus s) {
  switch (s) {
    case SlotStatus::kValid: return "valid";
    case SlotStatus::kMissing: return "missing";
    case SlotStatus::kTruncated: return "truncated";
    case SlotStatus::kBadMagic: return "not a calibration slot";
    case SlotStatus::kBadVersion: return "unknown format version";
    case SlotStatus::kBadCrc: return "CRC mismatch (corrupt)";
    case SlotStatus::kBadContent: return "invalid content";
  }
  return "unknown";
}

size_t calib_encode(const CalibrationData& d, uint32_t seq, uint8_t* out, size_t cap) {
  if (cap < calib_image_size()) return 0;
  Out o{out};
  std::memcpy(o.p, kMagic, 4);
  o.p += 4;
  o.u32(kFormatVersion);
  o.u32(seq);
  o.u32(uint32_t(kPayloadBytes));
  uint8_t* crc_at = o.p;
  o.p += 4;
  o.u32(uint32_t(d.pair_count));
  for (int i = 0; i < kCalibPairsMax; ++i) {
    const SensorPair& p = i < d.pair_count ? d.pairs[i] : SensorPair{};
    o.name(p.from);
    o.name(p.to);
    o.pose(p.T_from_to);
  }
  o.u32(uint32_t(d.intrinsic_count));
  for (int i = 0; i < kCalibIntrinsicsMax; ++i) {
    const IntrinsicOverride& k = i < d.intrinsic_count ? d.intrinsics[i] : IntrinsicOverride{};
    o.name(k.sensor);
    o.f32(k.fx);
    o.f32(k.fy);
    o.f32(k.cx);
    o.f32(k.cy);
  }
  o.pose(d.T_flange_rig);
  o.pose(d.T_world_bin);
  // CRC over the header (with the CRC field zero) and the payload.
  std::memset(crc_at, 0, 4);
  const uint32_t c = link::crc32(out, calib_image_size());
  Out{crc_at}.u32(c);
  return calib_image_size();
}

SlotStatus calib_decode(const uint8_t* in, size_t len, CalibrationData& d, uint32_t& seq) {
  if (len == 0) return SlotStatus::kMissing;
  if (len < kCalibHeaderBytes) return SlotStatus::kTruncated;
  if (std::memcmp(in, kMagic, 4) != 0) return SlotStatus::kBadMagic;
  In h{in + 4};
  const uint32_t version = h.u32();
  const uint32_t s = h.u32();
  const uint32_t payload = h.u32();
  const uint32_t want = h.u32();
  if (version != kFormatVersion) return SlotStatus::kBadVersion;
  if (payload != kPayloadBytes || len < kCalibHeaderBytes + payload) return SlotStatus::kTruncated;
  if (len != calib_image_size()) return SlotStatus::kBadContent;
  uint32_t c = link::crc32(in, 16);
  const uint8_t zero[4] = {0, 0, 0, 0};
  c = link::crc32(zero, 4, c);
  c = link::crc32(in + kCalibHeaderBytes, kPayloadBytes, c);
  if (c != want) return SlotStatus::kBadCrc;

  CalibrationData r;
  In i{in + kCalibHeaderBytes};
  const uint32_t pairs = i.u32();
  if (pairs > uint32_t(kCalibPairsMax)) return SlotStatus::kBadContent;
  r.pair_count = int(pairs);
  for (int k = 0; k < kCalibPairsMax; ++k)
    if (!i.name(r.pairs[k].from) || !i.name(r.pairs[k].to) || !i.pose(r.pairs[k].T_from_to))
      return SlotStatus::kBadContent;
  const uint32_t intr = i.u32();
  if (intr > uint32_t(kCalibIntrinsicsMax)) return SlotStatus::kBadContent;
  r.intrinsic_count = int(intr);
  for (int k = 0; k < kCalibIntrinsicsMax; ++k) {
    IntrinsicOverride& o = r.intrinsics[k];
    if (!i.name(o.sensor)) return SlotStatus::kBadContent;
    o.fx = i.f32();
    o.fy = i.f32();
    o.cx = i.f32();
    o.cy = i.f32();
  }
  if (!i.pose(r.T_flange_rig) || !i.pose(r.T_world_bin)) return SlotStatus::kBadContent;
  d = r;
  seq = s;
  return SlotStatus::kValid;
}

}  // namespace edgefuse::runtime
