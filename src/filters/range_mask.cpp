#include "edgefuse/filters/range_mask.hpp"

#include "view_checks.hpp"

namespace edgefuse {

namespace {
// Nearest raw step of a bound in metres, clamped to the 16-bit range.
int32_t raw_bound(float metres, float depth_scale) {
  const double r = double(metres) * double(depth_scale) + 0.5;
  if (r >= 65535.0) return 65535;
  return int32_t(r);  // r >= 0.5: truncation is the floor
}
}  // namespace

Status range_mask(ImageView<const uint16_t> depth, const RangeMaskParams& params, float depth_scale,
                  ImageView<uint16_t> out) {
  using namespace filters_detail;
  if (!params.valid() || !(depth_scale > 0) || !usable(depth) || !usable(out) || !same_size(depth, out) ||
      !in_place_or_disjoint(depth, out))
    return Status::kInvalidArgument;
  // Raw 0 means "no measurement" and is never kept, even with min_m = 0.
  const int32_t lo_raw = raw_bound(params.min_m, depth_scale);
  const int32_t lo = lo_raw > 0 ? lo_raw : 1;
  const int32_t hi = raw_bound(params.max_m, depth_scale);
  for (int v = 0; v < depth.height; ++v) {
    const uint16_t* in = depth.row(v);
    uint16_t* o = out.row(v);
    for (int u = 0; u < depth.width; ++u) {
      const int32_t z = in[u];
      o[u] = (z >= lo && z <= hi) ? uint16_t(z) : uint16_t(0);
    }
  }
  return Status::kOk;
}

}  // namespace edgefuse
