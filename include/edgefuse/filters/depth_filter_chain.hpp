// The depth pre-filters in the order the tracker / integrator needs them, behind one call:
//   range mask -> amplitude threshold (when an amplitude image is given) -> jump edges -> bilateral.
// Masks first, so that out-of-range and weak pixels neither count as neighbours of the jump-edge
// test nor leak into the bilateral average; jump edges before smoothing, so that mixed pixels are
// not averaged into the surfaces around them.
#pragma once

#include <cstdint>

#include "edgefuse/core/image.hpp"
#include "edgefuse/core/status.hpp"
#include "edgefuse/filters/amplitude_mask.hpp"
#include "edgefuse/filters/bilateral.hpp"
#include "edgefuse/filters/jump_edge.hpp"
#include "edgefuse/filters/range_mask.hpp"
#include "edgefuse/sensor/pinhole.hpp"

namespace edgefuse {

enum class DepthSensorKind {
  kStructuredLight,  //!< Xtion / Kinect v1 class: range mask + bilateral
  kTimeOfFlight,     //!< PMD / CamBoard class: range + amplitude + jump edges + bilateral (ToF sigma)
};

template <class Real>
struct DepthFilterChain {
  bool range_enabled = true;      //!< apply the range mask
  RangeMaskParams range;          //!< range interval
  bool amplitude_enabled = true;  //!< apply the amplitude threshold when run() gets an amplitude image
  AmplitudeMaskParams amplitude;  //!< amplitude threshold
  bool jump_edge_enabled = true;  //!< apply the jump-edge filter
  JumpEdgeParams jump_edge;       //!< jump-edge threshold
  bool bilateral_enabled = true;  //!< apply the bilateral filter
  BilateralParams bilateral;      //!< bilateral sigmas

  //! The paper's pre-filtering per sensor kind: both get the sensor's range interval and the
  //! bilateral filter (ToF with its wider range sigma); only ToF gets the amplitude threshold and
  //! jump-edge filter (structured light has no amplitude image, and its correlation window reports
  //! the foreground or the background at an edge, not depths in between). Call prepare() afterwards.
  //! \param intr sensor intrinsics (range interval)
  //! \param kind sensor technology
  static DepthFilterChain defaults_for(const PinholeIntrinsics& intr, DepthSensorKind kind);

  //! Validates the enabled steps' parameters and builds their tables (start-up, not per frame).
  //! \param intr intrinsics of the depth images run() will get
  //! \return kInvalidArgument when an enabled step's parameters or the intrinsics are invalid
  Status prepare(const PinholeIntrinsics& intr);

  //! Filters one frame. Uses `scratch` as the intermediate buffer; the result is in `out`. depth
  //! may be `out` itself (the first step is pixel-wise), never `scratch`.
  //! \param depth raw z-depth, 0 = invalid, size of the prepared intrinsics
  //! \param amplitude_image amplitude of the same size, or an empty view (no amplitude step)
  //! \param scratch caller's buffer of the same size, not overlapping depth or out
  //! \param out filtered depth, same size
  //! \return kNotInitialised before prepare(); kInvalidArgument on size mismatch or overlap
  Status run(ImageView<const uint16_t> depth, ImageView<const uint16_t> amplitude_image, ImageView<uint16_t> scratch,
             ImageView<uint16_t> out) const;

  // Built by prepare().
  JumpEdgeKernel<Real> jump_kernel;  //!< jump-edge constants
  BilateralKernel bilateral_kernel;  //!< bilateral tables
  float depth_scale = 0;             //!< of the prepared intrinsics
  int width = 0, height = 0;         //!< of the prepared intrinsics
  bool prepared = false;             //!< prepare() succeeded
};

}  // namespace edgefuse
