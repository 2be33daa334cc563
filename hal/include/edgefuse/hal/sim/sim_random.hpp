// Deterministic noise for the simulated sensors (xorshift64*, Box-Muller): a seed reproduces a
// run bit for bit, and nothing allocates.
#pragma once

#include <cmath>
#include <cstdint>

namespace edgefuse::hal {

class SimRandom {
 public:
  //! \param seed any value (0 is mapped to a fixed non-zero state)
  explicit SimRandom(uint64_t seed = 1) { reseed(seed); }
  void reseed(uint64_t seed) { state_ = seed ? seed : 0x9E3779B97F4A7C15ull; }
  uint64_t next() {
    state_ ^= state_ >> 12;
    state_ ^= state_ << 25;
    state_ ^= state_ >> 27;
    return state_ * 0x2545F4914F6CDD1Dull;
  }
  //! Uniform in [0, 1).
  float uniform() { return float(next() >> 40) * (1.0f / 16777216.0f); }
  //! Standard normal.
  float gaussian() {
    const float u1 = uniform() + 1e-7f, u2 = uniform();
    return std::sqrt(-2.0f * std::log(u1)) * std::cos(6.28318530718f * u2);
  }

 private:
  uint64_t state_;
};

}  // namespace edgefuse::hal
