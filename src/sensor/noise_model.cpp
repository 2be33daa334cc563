#include "edgefuse/sensor/noise_model.hpp"

namespace edgefuse {

Status build_trust_map(const NoiseModel& model, float sigma_ref_m, ImageView<const uint16_t> depth, float depth_scale,
                       ImageView<const uint16_t> amplitude, ImageView<uint8_t> trust, float sigma_max_m) {
  if (!model.valid() || !(sigma_ref_m > 0.0f) || !(sigma_max_m >= 0.0f) || !(depth_scale > 0.0f) || depth.empty()) return Status::kInvalidArgument;
  if (trust.empty() || trust.width != depth.width || trust.height != depth.height) return Status::kInvalidArgument;
  const bool amp = !amplitude.empty();
  if (amp && (amplitude.width != depth.width || amplitude.height != depth.height)) return Status::kInvalidArgument;
  const float inv_scale = 1.0f / depth_scale;
  for (int v = 0; v < depth.height; ++v)
    for (int u = 0; u < depth.width; ++u) {
      const uint16_t raw = depth.at(u, v);
      if (raw == 0) {
        trust.at(u, v) = 0;
        continue;
      }
      const float z_m = float(raw) * inv_scale, a = amp ? float(amplitude.at(u, v)) : 0.0f;
      if (sigma_max_m > 0.0f && model.sigma_m(z_m, a) > sigma_max_m) {
        trust.at(u, v) = 0;
        continue;
      }
      const float t = model.trust(sigma_ref_m, z_m, a);
      const int q = int(t * 255.0f + 0.5f);
      trust.at(u, v) = uint8_t(q < 1 ? 1 : (q > 255 ? 255 : q));
    }
  return Status::kOk;
}

}  // namespace edgefuse
