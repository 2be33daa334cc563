// Q16.16: conversions, rounding (to nearest, ties away from zero) and saturation.
#include <cmath>
#include <cstdint>

#include "edgefuse/math/fixed.hpp"
#include "edgefuse/math/real.hpp"
#include "test_support.hpp"

using edgefuse::Fixed;

TEST_GROUP(FixedPoint){};

TEST(FixedPoint, ConversionRoundsToNearestTiesAwayFromZero) {
  CHECK_EQUAL(65536, Fixed::from_float(1.0f).raw());
  CHECK_EQUAL(-65536, Fixed::from_float(-1.0f).raw());
  CHECK_EQUAL(2, Fixed::from_float(1.5f / 65536).raw());    // tie -> away from zero
  CHECK_EQUAL(-2, Fixed::from_float(-1.5f / 65536).raw());  // symmetric
  CHECK_EQUAL(1, Fixed::from_float(1.4f / 65536).raw());
  CHECK_EQUAL(0, Fixed::from_float(0.49f / 65536).raw());
  CHECK_EQUAL(0, Fixed::from_float(NAN).raw());
  DOUBLES_EQUAL(0.123456, Fixed::from_float(0.123456f).to_float(), 1.0 / 65536);
  CHECK_EQUAL(3, Fixed::from_float(2.5f).round_to_int());
  CHECK_EQUAL(-3, Fixed::from_float(-2.5f).round_to_int());
  CHECK_EQUAL(-3, Fixed::from_float(-2.5f).floor_to_int());
  CHECK_EQUAL(2, Fixed::from_float(2.99f).floor_to_int());
}

TEST(FixedPoint, ArithmeticMatchesFloatWithinOneStep) {
  const float values[] = {0.0f, 1.0f, -1.0f, 0.7071f, -3.25f, 123.456f, -0.001f, 2.0e-4f};
  for (float a : values)
    for (float b : values) {
      // Compare raw steps against the exact result: each operation is off by at most half a step.
      const Fixed fa = Fixed::from_float(a), fb = Fixed::from_float(b);
      const double x = double(fa.raw()) / 65536, y = double(fb.raw()) / 65536;
      DOUBLES_EQUAL((x + y) * 65536, double((fa + fb).raw()), 0.5);
      DOUBLES_EQUAL((x - y) * 65536, double((fa - fb).raw()), 0.5);
      DOUBLES_EQUAL(x * y * 65536, double((fa * fb).raw()), 0.5);
      if (std::fabs(y) > 1e-3 && std::fabs(x / y) < 30000) DOUBLES_EQUAL(x / y * 65536, double((fa / fb).raw()), 0.5);
    }
}

TEST(FixedPoint, SaturatesInsteadOfWrapping) {
  const Fixed big = Fixed::from_float(30000.0f);
  CHECK_EQUAL(Fixed::kRawMax, (big + big).raw());
  CHECK_EQUAL(Fixed::kRawMin, (-big - big).raw());
  CHECK_EQUAL(Fixed::kRawMax, (big * big).raw());
  CHECK_EQUAL(Fixed::kRawMin, (big * -big).raw());
  CHECK_EQUAL(Fixed::kRawMax, Fixed::from_float(1e9f).raw());
  CHECK_EQUAL(Fixed::kRawMin, Fixed::from_float(-1e9f).raw());
  CHECK_EQUAL(Fixed::kRawMax, (Fixed::from_int(1) / Fixed::from_raw(0)).raw());
  CHECK_EQUAL(Fixed::kRawMin, (Fixed::from_int(-1) / Fixed::from_raw(0)).raw());
  CHECK_EQUAL(Fixed::kRawMax, (-Fixed::from_raw(Fixed::kRawMin)).raw());
}

TEST(FixedPoint, SquareRootRoundsToNearest) {
  DOUBLES_EQUAL(2.0, sqrt(Fixed::from_int(4)).to_float(), 0);
  DOUBLES_EQUAL(std::sqrt(2.0), sqrt(Fixed::from_int(2)).to_float(), 1.0 / 65536);
  DOUBLES_EQUAL(std::sqrt(0.49), sqrt(Fixed::from_float(0.49f)).to_float(), 1.0 / 65536);
  DOUBLES_EQUAL(std::sqrt(30000.0), sqrt(Fixed::from_int(30000)).to_float(), 1.0 / 65536);
  CHECK_EQUAL(0, sqrt(Fixed::from_int(-4)).raw());
  for (int32_t raw = 1; raw < 2000000; raw += 997) {
    const double exact = std::sqrt(double(raw) / 65536) * 65536;
    CHECK(std::fabs(sqrt(Fixed::from_raw(raw)).raw() - exact) <= 0.5 + 1e-9);
  }
}

TEST(FixedPoint, DepthScaleKeepsFullPrecision) {
  const edgefuse::DepthScale<Fixed> s5000(5000.0f);
  const edgefuse::DepthScale<float> f5000(5000.0f);
  for (uint16_t raw : {uint16_t(1), uint16_t(3500), uint16_t(5000), uint16_t(17500), uint16_t(65535)})
    DOUBLES_EQUAL(f5000.metres(raw), s5000.metres(raw).to_float(), 1.0 / 65536);
}
