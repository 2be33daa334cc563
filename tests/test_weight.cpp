// The Bylow weight (eq. 2) at and around its boundaries, and its integer table.
#include <cmath>

#include "edgefuse/tsdf/weight.hpp"
#include "test_support.hpp"

using namespace edgefuse;

TEST_GROUP(Weight){};

TEST(Weight, ValuesAtTheBoundaries) {
  const WeightParams p = WeightParams::defaults_for(0.04f);
  DOUBLES_EQUAL(0.01, p.eps_m, 1e-7);
  DOUBLES_EQUAL(0.04, p.rho_m, 1e-7);
  DOUBLES_EQUAL(1.0, bylow_weight(0.5f, p), 0);          // in front: full weight
  DOUBLES_EQUAL(1.0, bylow_weight(0.0f, p), 0);          // on the surface
  DOUBLES_EQUAL(1.0, bylow_weight(-p.eps_m, p), 0);      // d = -eps still full
  DOUBLES_EQUAL(1.0, bylow_weight(-p.eps_m - 1e-6f, p), 1e-4);  // continuous just behind -eps
  DOUBLES_EQUAL(std::exp(-3.0), bylow_weight(-p.rho_m + 1e-7f, p), 1e-3);  // e^-3 just before -rho
  DOUBLES_EQUAL(0.0, bylow_weight(-p.rho_m, p), 0);      // d = -rho: no update
  DOUBLES_EQUAL(0.0, bylow_weight(-1.0f, p), 0);
  // Halfway through the band: exp(-sigma (band/2)^2) = exp(-3/4).
  DOUBLES_EQUAL(std::exp(-0.75), bylow_weight(-(p.eps_m + p.rho_m) / 2, p), 1e-5);
}

TEST(Weight, MonotonicBehindTheSurface) {
  const WeightParams p = WeightParams::defaults_for(0.02f);
  float prev = 1.0f;
  for (int i = 0; i <= 100; ++i) {
    const float w = bylow_weight(-0.0201f * float(i) / 100.0f, p);
    CHECK(w <= prev + 1e-7f);
    prev = w;
  }
}

TEST(Weight, TableSamplesTheFunction) {
  const WeightParams p = WeightParams::defaults_for(0.04f);
  WeightTable t;
  t.build(p);
  CHECK(t.shape[0] >= 255 && t.shape[0] <= 256);
  CHECK(std::abs(int(t.shape[WeightTable::kSize - 1]) - int(std::lround(256 * std::exp(-3.0)))) <= 1);
  for (int i = 1; i < WeightTable::kSize; ++i) CHECK(t.shape[i] <= t.shape[i - 1]);
}

TEST(Weight, InvalidParametersAreDetected) {
  WeightParams p = WeightParams::defaults_for(0.04f);
  CHECK(p.valid());
  p.rho_m = p.eps_m;
  CHECK_FALSE(p.valid());
}
