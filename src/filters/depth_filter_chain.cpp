#include "edgefuse/filters/depth_filter_chain.hpp"

#include "view_checks.hpp"

namespace edgefuse {

template <class Real>
DepthFilterChain<Real> DepthFilterChain<Real>::defaults_for(const PinholeIntrinsics& intr, DepthSensorKind kind) {
  DepthFilterChain c;
  c.range = RangeMaskParams::from_sensor(intr);
  const bool tof = kind == DepthSensorKind::kTimeOfFlight;
  c.amplitude_enabled = tof;
  c.jump_edge_enabled = tof;
  c.bilateral = tof ? BilateralParams::time_of_flight() : BilateralParams();
  return c;
}

template <class Real>
Status DepthFilterChain<Real>::prepare(const PinholeIntrinsics& intr) {
  prepared = false;
  if (intr.validate() != Status::kOk) return Status::kInvalidArgument;
  if (range_enabled && !range.valid()) return Status::kInvalidArgument;
  if (amplitude_enabled && !amplitude.valid()) return Status::kInvalidArgument;
  if (jump_edge_enabled && jump_kernel.prepare(jump_edge, intr) != Status::kOk) return Status::kInvalidArgument;
  if (bilateral_enabled && bilateral_kernel.prepare(bilateral, intr.depth_scale) != Status::kOk)
    return Status::kInvalidArgument;
  depth_scale = intr.depth_scale;
  width = intr.width;
  height = intr.height;
  prepared = true;
  return Status::kOk;
}

template <class Real>
Status DepthFilterChain<Real>::run(ImageView<const uint16_t> depth, ImageView<const uint16_t> amplitude_image,
                                   ImageView<uint16_t> scratch, ImageView<uint16_t> out) const {
  using namespace filters_detail;
  if (!prepared) return Status::kNotInitialised;
  const bool with_amplitude = amplitude_enabled && !amplitude_image.empty();
  if (!usable(depth) || !usable(scratch) || !usable(out) || depth.width != width || depth.height != height ||
      !same_size(depth, scratch) || !same_size(depth, out) || overlap(scratch, out) || overlap(depth, scratch) ||
      !in_place_or_disjoint(depth, out) ||
      (with_amplitude && (!usable(amplitude_image) || !same_size(depth, amplitude_image) ||
                          overlap(amplitude_image, out) || overlap(amplitude_image, scratch))))
    return Status::kInvalidArgument;

  // The pixel-wise masks write where the neighbourhood steps can then ping-pong to end in `out`:
  // two neighbourhood steps go out -> scratch -> out, one goes scratch -> out.
  const int neighbourhood_steps = (jump_edge_enabled ? 1 : 0) + (bilateral_enabled ? 1 : 0);
  const ImageView<uint16_t> masked = neighbourhood_steps == 1 ? scratch : out;
  ImageView<const uint16_t> src = depth;
  Status s = Status::kOk;
  if (range_enabled) {
    s = range_mask(src, range, depth_scale, masked);
    src = masked;
  }
  if (s == Status::kOk && with_amplitude) {
    s = amplitude_mask(src, amplitude_image, amplitude, masked);
    src = masked;
  }
  if (s == Status::kOk && src.data != masked.data) {  // no mask ran: start from a copy
    for (int v = 0; v < height; ++v) {
      const uint16_t* a = src.row(v);
      uint16_t* b = masked.row(v);
      for (int u = 0; u < width; ++u) b[u] = a[u];
    }
  }
  if (s != Status::kOk) return s;
  if (neighbourhood_steps == 2) {
    s = remove_jump_edges<Real>(out, jump_kernel, scratch);
    if (s == Status::kOk) s = bilateral_filter(scratch, bilateral_kernel, out);
  } else if (jump_edge_enabled) {
    s = remove_jump_edges<Real>(scratch, jump_kernel, out);
  } else if (bilateral_enabled) {
    s = bilateral_filter(scratch, bilateral_kernel, out);
  }
  return s;
}

template struct DepthFilterChain<float>;
template struct DepthFilterChain<Fixed>;

}  // namespace edgefuse
