#include "edgefuse/filters/amplitude_mask.hpp"

#include "view_checks.hpp"

namespace edgefuse {

Status amplitude_mask(ImageView<const uint16_t> depth, ImageView<const uint16_t> amplitude,
                      const AmplitudeMaskParams& params, ImageView<uint16_t> out) {
  using namespace filters_detail;
  if (!params.valid() || !usable(depth) || !usable(amplitude) || !usable(out) || !same_size(depth, amplitude) ||
      !same_size(depth, out) || !in_place_or_disjoint(depth, out) || overlap(amplitude, out))
    return Status::kInvalidArgument;
  const uint16_t threshold = params.min_amplitude;
  for (int v = 0; v < depth.height; ++v) {
    const uint16_t* in = depth.row(v);
    const uint16_t* a = amplitude.row(v);
    uint16_t* o = out.row(v);
    for (int u = 0; u < depth.width; ++u) o[u] = a[u] >= threshold ? in[u] : uint16_t(0);
  }
  return Status::kOk;
}

}  // namespace edgefuse
