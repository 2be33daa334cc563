// Q16.16 fixed-point scalar for boards without a fast FPU (e.g. Cortex-A8 VFPLite).
//
// Representation: a signed 32-bit integer `raw`, value = raw / 65536.
//   range      [-32768, 32767.99998] (metres, or whatever unit the caller uses)
//   resolution 1/65536 = 1.53e-5 (15 um when the unit is the metre)
//
// Rounding: every operation rounds to the nearest representable value, ties away from zero
// (the same rule as std::lround), so results are symmetric for positive and negative inputs.
// Saturation: a result outside the range is clamped to the largest / smallest value instead of
// wrapping; division by zero saturates to the largest magnitude with the dividend's sign.
// Products and quotients are computed in 64 bits, so no intermediate overflow is possible.
#pragma once

#include <cstdint>

namespace edgefuse {

class Fixed {
 public:
  static constexpr int kFracBits = 16;
  static constexpr int32_t kOne = 1 << kFracBits;
  static constexpr int32_t kRawMax = INT32_MAX;
  static constexpr int32_t kRawMin = INT32_MIN;

  constexpr Fixed() = default;

  //! Build from a raw Q16.16 integer (no conversion).
  //! \param raw value * 65536
  static constexpr Fixed from_raw(int32_t raw) {
    Fixed f;
    f.raw_ = raw;
    return f;
  }
  //! Convert an integer, saturating.
  //! \param v integer value
  static constexpr Fixed from_int(int32_t v) { return from_raw(saturate(int64_t(v) * kOne)); }
  //! Convert a float, rounding to nearest (ties away from zero) and saturating.
  //! \param v value in the caller's unit
  static constexpr Fixed from_float(float v) {
    const double scaled = double(v) * kOne;
    if (!(scaled == scaled)) return from_raw(0);  // NaN maps to zero, never to garbage
    if (scaled >= double(kRawMax)) return from_raw(kRawMax);
    if (scaled <= double(kRawMin)) return from_raw(kRawMin);
    return from_raw(int32_t(scaled >= 0 ? scaled + 0.5 : scaled - 0.5));
  }

  constexpr int32_t raw() const { return raw_; }
  constexpr float to_float() const { return float(raw_) * (1.0f / kOne); }
  //! Round to the nearest integer, ties away from zero.
  constexpr int32_t round_to_int() const {
    return raw_ >= 0 ? int32_t((int64_t(raw_) + kOne / 2) >> kFracBits)
                     : -int32_t((-int64_t(raw_) + kOne / 2) >> kFracBits);
  }
  //! Largest integer not greater than the value.
  constexpr int32_t floor_to_int() const { return raw_ >> kFracBits; }

  friend constexpr Fixed operator+(Fixed a, Fixed b) { return from_raw(saturate(int64_t(a.raw_) + b.raw_)); }
  friend constexpr Fixed operator-(Fixed a, Fixed b) { return from_raw(saturate(int64_t(a.raw_) - b.raw_)); }
  friend constexpr Fixed operator-(Fixed a) { return from_raw(saturate(-int64_t(a.raw_))); }
  friend constexpr Fixed operator*(Fixed a, Fixed b) {
    return from_raw(saturate(round_shift(int64_t(a.raw_) * b.raw_, kFracBits)));
  }
  friend constexpr Fixed operator/(Fixed a, Fixed b) {
    if (b.raw_ == 0) return from_raw(a.raw_ >= 0 ? kRawMax : kRawMin);
    return from_raw(saturate(round_div(int64_t(a.raw_) * kOne, b.raw_)));
  }
  Fixed& operator+=(Fixed b) { return *this = *this + b; }
  Fixed& operator-=(Fixed b) { return *this = *this - b; }
  Fixed& operator*=(Fixed b) { return *this = *this * b; }
  Fixed& operator/=(Fixed b) { return *this = *this / b; }

  friend constexpr bool operator<(Fixed a, Fixed b) { return a.raw_ < b.raw_; }
  friend constexpr bool operator>(Fixed a, Fixed b) { return a.raw_ > b.raw_; }
  friend constexpr bool operator<=(Fixed a, Fixed b) { return a.raw_ <= b.raw_; }
  friend constexpr bool operator>=(Fixed a, Fixed b) { return a.raw_ >= b.raw_; }
  friend constexpr bool operator==(Fixed a, Fixed b) { return a.raw_ == b.raw_; }
  friend constexpr bool operator!=(Fixed a, Fixed b) { return a.raw_ != b.raw_; }

  //! Square root, rounded to nearest; negative input gives 0.
  friend constexpr Fixed sqrt(Fixed a) {
    if (a.raw_ <= 0) return from_raw(0);
    // sqrt(raw / 2^16) * 2^16 = sqrt(raw * 2^16): integer square root of a 48-bit number.
    const uint64_t n = uint64_t(a.raw_) << kFracBits;
    uint64_t r = isqrt(n);
    if (n - r * r > r) ++r;  // round to nearest: (r + 0.5)^2 = r^2 + r + 0.25
    return from_raw(int32_t(r));
  }

  static constexpr int32_t saturate(int64_t v) {
    return v > kRawMax ? kRawMax : (v < kRawMin ? kRawMin : int32_t(v));
  }
  //! v / 2^s rounded to nearest, ties away from zero.
  static constexpr int64_t round_shift(int64_t v, int s) {
    const int64_t half = int64_t(1) << (s - 1);
    return v >= 0 ? (v + half) >> s : -((-v + half) >> s);
  }
  //! n / d rounded to nearest, ties away from zero.
  static constexpr int64_t round_div(int64_t n, int64_t d) {
    const bool neg = (n < 0) != (d < 0);
    const uint64_t un = n < 0 ? uint64_t(-n) : uint64_t(n);
    const uint64_t ud = d < 0 ? uint64_t(-d) : uint64_t(d);
    const uint64_t q = (un + ud / 2) / ud;
    return neg ? -int64_t(q) : int64_t(q);
  }
  static constexpr uint64_t isqrt(uint64_t n) {
    uint64_t res = 0;
    uint64_t bit = uint64_t(1) << 62;
    while (bit > n) bit >>= 2;
    while (bit != 0) {
      if (n >= res + bit) {
        n -= res + bit;
        res = (res >> 1) + bit;
      } else {
        res >>= 1;
      }
      bit >>= 2;
    }
    return res;
  }

 private:
  int32_t raw_ = 0;
};

}  // namespace edgefuse
