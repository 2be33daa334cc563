// Range mask and amplitude threshold: exact integer boundaries, in-place use, invalid pixels stay
// invalid, and argument errors.
#include <cstdint>
#include <vector>

#include "edgefuse/filters/amplitude_mask.hpp"
#include "edgefuse/filters/range_mask.hpp"
#include "test_support.hpp"

using namespace edgefuse;

namespace {
using View = ImageView<uint16_t>;
using CView = ImageView<const uint16_t>;
}  // namespace

TEST_GROUP(FilterMasks){};

TEST(FilterMasks, RangeMaskKeepsExactlyTheInclusiveInterval) {
  // Scale 5000: 0.1 m = raw 500, 1.0 m = raw 5000.
  const std::vector<uint16_t> in = {0, 1, 499, 500, 501, 4999, 5000, 5001, 65535, 0};
  const std::vector<uint16_t> expect = {0, 0, 0, 500, 501, 4999, 5000, 0, 0, 0};
  std::vector<uint16_t> out(in.size(), 7);
  RangeMaskParams p;
  p.min_m = 0.1f;
  p.max_m = 1.0f;
  CHECK(range_mask(CView(in.data(), 5, 2), p, 5000.0f, View(out.data(), 5, 2)) == Status::kOk);
  for (std::size_t i = 0; i < in.size(); ++i) LONGS_EQUAL(expect[i], out[i]);
}

TEST(FilterMasks, RangeMaskFromSensorInPlaceAndWithStride) {
  PinholeIntrinsics c;
  c.min_range_m = 0.4f;
  c.max_range_m = 3.5f;
  const RangeMaskParams p = RangeMaskParams::from_sensor(c);
  DOUBLES_EQUAL(0.4, p.min_m, 1e-7);
  DOUBLES_EQUAL(3.5, p.max_m, 1e-7);
  // 3 x 2 pixels in rows of stride 4; the padding column must not be touched.
  std::vector<uint16_t> buf = {1999, 2000, 17500, 99, 17501, 0, 3000, 99};
  View v(buf.data(), 3, 2, 4);
  CHECK(range_mask(CView(v), p, 5000.0f, v) == Status::kOk);
  const std::vector<uint16_t> expect = {0, 2000, 17500, 99, 0, 0, 3000, 99};
  for (std::size_t i = 0; i < buf.size(); ++i) LONGS_EQUAL(expect[i], buf[i]);
}

TEST(FilterMasks, RangeMaskNeverKeepsRawZero) {
  std::vector<uint16_t> buf = {0, 1, 2};
  RangeMaskParams p;
  p.min_m = 0.0f;
  p.max_m = 1.0f;
  View v(buf.data(), 3, 1);
  CHECK(range_mask(CView(v), p, 1000.0f, v) == Status::kOk);
  LONGS_EQUAL(0, buf[0]);
  LONGS_EQUAL(1, buf[1]);
}

TEST(FilterMasks, RangeMaskRejectsBadArguments) {
  std::vector<uint16_t> a(16, 1000), b(12);
  const CView in(a.data(), 4, 3);
  RangeMaskParams p;
  CHECK(p.valid());
  CHECK(range_mask(in, p, 1000.0f, View(b.data(), 3, 4)) == Status::kInvalidArgument);      // size
  CHECK(range_mask(in, p, 1000.0f, View(nullptr, 4, 3)) == Status::kInvalidArgument);       // empty
  CHECK(range_mask(in, p, 0.0f, View(b.data(), 4, 3)) == Status::kInvalidArgument);         // scale
  CHECK(range_mask(in, p, 1000.0f, View(a.data() + 1, 4, 3)) == Status::kInvalidArgument);  // shifted overlap
  CHECK(range_mask(CView(a.data(), 4, 3, 2), p, 1000.0f, View(b.data(), 4, 3)) == Status::kInvalidArgument);  // stride
  p.min_m = 2.0f;
  p.max_m = 1.0f;
  CHECK_FALSE(p.valid());
  CHECK(range_mask(in, p, 1000.0f, View(b.data(), 4, 3)) == Status::kInvalidArgument);
  p.min_m = -0.1f;
  CHECK(range_mask(in, p, 1000.0f, View(b.data(), 4, 3)) == Status::kInvalidArgument);
}

TEST(FilterMasks, AmplitudeThresholdIsExact) {
  const std::vector<uint16_t> depth = {3000, 3000, 3000, 0, 3000, 3000};
  const std::vector<uint16_t> amp = {0, 399, 400, 9000, 401, 65535};
  const std::vector<uint16_t> expect = {0, 0, 3000, 0, 3000, 3000};
  std::vector<uint16_t> out(depth.size(), 7);
  AmplitudeMaskParams p;
  LONGS_EQUAL(400, p.min_amplitude);
  CHECK(amplitude_mask(CView(depth.data(), 3, 2), CView(amp.data(), 3, 2), p, View(out.data(), 3, 2)) == Status::kOk);
  for (std::size_t i = 0; i < out.size(); ++i) LONGS_EQUAL(expect[i], out[i]);
  // In place gives the same.
  std::vector<uint16_t> buf = depth;
  View v(buf.data(), 3, 2);
  CHECK(amplitude_mask(CView(v), CView(amp.data(), 3, 2), p, v) == Status::kOk);
  for (std::size_t i = 0; i < out.size(); ++i) LONGS_EQUAL(expect[i], buf[i]);
}

TEST(FilterMasks, AmplitudeThresholdRejectsBadArguments) {
  std::vector<uint16_t> d(6, 1000), a(6, 1000), o(6);
  AmplitudeMaskParams p;
  CHECK(amplitude_mask(CView(d.data(), 3, 2), CView(a.data(), 2, 3), p, View(o.data(), 3, 2)) ==
        Status::kInvalidArgument);
  CHECK(amplitude_mask(CView(d.data(), 3, 2), CView(a.data(), 3, 2), p, View(o.data(), 2, 3)) ==
        Status::kInvalidArgument);
  CHECK(amplitude_mask(CView(d.data(), 3, 2), CView(a.data(), 3, 2), p, View(a.data(), 3, 2)) ==
        Status::kInvalidArgument);  // writing over the amplitude
  p.min_amplitude = 0;
  CHECK_FALSE(p.valid());
  CHECK(amplitude_mask(CView(d.data(), 3, 2), CView(a.data(), 3, 2), p, View(o.data(), 3, 2)) ==
        Status::kInvalidArgument);
}
