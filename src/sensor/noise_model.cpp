#include "edgefuse/sensor/noise_model.hpp"

namespace edgefuse {

namespace {
// Median of the per-pixel noise without sorting: 0.25 mm bins up to 64 mm (the ToF model caps at 20 mm).
struct NoiseHistogram {
  static constexpr int kBins = 256;
  static constexpr float kBinM = 0.00025f;
  uint32_t bins[kBins] = {};
  uint32_t count = 0;
  void add(float sigma_m) {
    const int b = int(sigma_m / kBinM);
    ++bins[b < 0 ? 0 : (b >= kBins ? kBins - 1 : b)];
    ++count;
  }
  float median_m() const {
    uint32_t seen = 0;
    for (int b = 0; b < kBins && count > 0; ++b) {
      seen += bins[b];
      if (2 * seen >= count) return (float(b) + 0.5f) * kBinM;
    }
    return 0.0f;
  }
};
}  // namespace

Status build_trust_map(const NoiseModel& model, float sigma_ref_m, ImageView<const uint16_t> depth, float depth_scale,
                       ImageView<const uint16_t> amplitude, ImageView<uint8_t> trust, float sigma_max_m,
                       float* median_sigma_m) {
  if (!model.valid() || !(sigma_ref_m > 0.0f) || !(sigma_max_m >= 0.0f) || !(depth_scale > 0.0f) || depth.empty()) return Status::kInvalidArgument;
  if (trust.empty() || trust.width != depth.width || trust.height != depth.height) return Status::kInvalidArgument;
  const bool amp = !amplitude.empty();
  if (amp && (amplitude.width != depth.width || amplitude.height != depth.height)) return Status::kInvalidArgument;
  const float inv_scale = 1.0f / depth_scale;
  NoiseHistogram hist;
  for (int v = 0; v < depth.height; ++v)
    for (int u = 0; u < depth.width; ++u) {
      const uint16_t raw = depth.at(u, v);
      if (raw == 0) {
        trust.at(u, v) = 0;
        continue;
      }
      const float z_m = float(raw) * inv_scale, a = amp ? float(amplitude.at(u, v)) : 0.0f;
      const float sigma_m = model.sigma_m(z_m, a);  // once per pixel: gate, trust and median
      if (sigma_max_m > 0.0f && sigma_m > sigma_max_m) {
        trust.at(u, v) = 0;
        continue;
      }
      const float t = NoiseModel::trust_of_sigma(sigma_ref_m, sigma_m);
      const int q = int(t * 255.0f + 0.5f);
      trust.at(u, v) = uint8_t(q < 1 ? 1 : (q > 255 ? 255 : q));
      if (median_sigma_m != nullptr) hist.add(sigma_m);
    }
  if (median_sigma_m != nullptr) *median_sigma_m = hist.median_m();
  return Status::kOk;
}

}  // namespace edgefuse
