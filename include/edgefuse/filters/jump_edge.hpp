// Jumping-edge (flying / mixed pixel) filter for time-of-flight depth (paper: "ToF data was also
// filtered for jumping edges").
//
// A ToF pixel that straddles a depth discontinuity integrates light from the foreground and the
// background and reports a depth in between: a point floating in free space. The jump-edge
// literature (Tang et al. 2007; Fuchs & May 2008; May et al., "Three-dimensional mapping with
// time-of-flight cameras", 2009) detects it in the triangle camera O, point p, neighbour point
// p_n: with phi the apex angle between the two pixels' rays, the law of sines gives the triangle's
// angle at p as
//     xi_n:  sin(xi_n) = |p_n| sin(phi) / |p_n - p|,
// and p is removed when xi = max over the 8 neighbours of xi_n exceeds a threshold xi_th close to
// 180 deg. xi_n near 180 deg means p_n lies behind p almost on p's own viewing ray: the segment
// p -> p_n is nearly parallel to the ray, which a real surface only produces at grazing view.
// Because arcsin folds angles above 90 deg onto their supplement, the angle is evaluated through
// its cosine here (the obtuse case is the one that matters), i.e. p is removed when some valid
// neighbour's vector d = p_n - p makes an angle below alpha = 180 deg - xi_th with p's ray.
//
// Consequences: the mixed pixel (background behind it) and the one-pixel rim of the foreground
// silhouette (mixed pixel or background behind it) are removed; the background next to an object
// is kept (its neighbours across the edge are in front of it). A plane is kept while it is seen at
// incidence below 90 deg - alpha (80 deg at the default), so a plane tilted 60..75 deg towards the
// camera stays whole. Invalid neighbours and neighbours outside the image are ignored.
// A mixed pixel is only caught when the surface behind it is more than T* pixel footprints away
// (below). Measured on the 20 bin_rig_a ToF frames against the exact depth: 1.66 % of all pixels
// removed (README: 1.49 % flying), two thirds of them clean foreground rim, and 42 % of the pixels
// more than 4 sigma and 1 cm off the true surface caught; the others are mixed with a surface less
// than ~5 cm (5.7 footprints at 0.7 m) away. A lower threshold does not separate them from the
// ToF noise (6.7 mm median): at 160 deg 74 % are caught but 34 % of all valid pixels are removed.
//
// Evaluation without trigonometry per pixel: with r = (x, y, 1) the ray of p (x = (u - cx) / fx,
// y = (v - cy) / fy), delta = (du, dv fx / fy, 0) the neighbour's ray offset in units of 1 / fx and
// Delta = z_n - z_p, one has d = Delta r + (z_n / fx) delta; the angle between d and r falls below
// alpha exactly when
//     Delta fx / z_n > T* = (|delta x r| / tan(alpha) - delta . r) / |r|^2
// (Delta fx / z_n is the depth jump measured in pixel footprints at z_n; T* is about 5.7 footprints
// at the image centre for alpha = 10 deg). The test is scale free, so Delta and z_n are compared
// in raw depth units as 64-bit integers; T* (the back-projection geometry) is computed in Real,
// and only for pixels that pass a cheap lower bound of T* precomputed per image cell.
#pragma once

#include <cstdint>

#include "edgefuse/core/image.hpp"
#include "edgefuse/core/status.hpp"
#include "edgefuse/math/real.hpp"
#include "edgefuse/sensor/pinhole.hpp"

namespace edgefuse {

struct JumpEdgeParams {
  //! xi_th in degrees: a pixel is removed when the largest triangle angle xi exceeds it. Default
  //! 170 deg, i.e. a neighbour within alpha = 10 deg of the pixel's viewing ray behind it (the
  //! order of the thresholds of the jump-edge literature). Physically: surfaces seen at more than
  //! 80 deg incidence are dropped (the Xtion model of bin_rig_a already loses them beyond 75 deg,
  //! and a ToF return at such an angle is weak and mostly mixed), while at the ToF's 80 px focal
  //! length and 0.7 m range a depth step larger than 5.7 pixel footprints (5 cm) is cut.
  float max_angle_deg = 170.0f;

  //! 90 < max_angle_deg < 180 (alpha between 0 and 90 deg).
  bool valid() const { return max_angle_deg > 90.0f && max_angle_deg < 180.0f; }
};

//! The camera constants of the test in the kernel scalar, built once per sensor by prepare().
template <class Real>
struct JumpEdgeKernel {
  //! The image is split into kGrid x kGrid cells, each with a lower bound of T* over its pixels
  //! and the 8 directions: pixels without a neighbour jumping beyond it skip the exact test.
  static constexpr int kGrid = 16;

  int width = 0, height = 0;              //!< image size the kernel was prepared for
  Real fx{}, fy{};                        //!< focal lengths (pixels)
  Real cx{}, cy{};                        //!< principal point (pixels)
  Real aspect{};                          //!< fx / fy: vertical ray step in units of the horizontal one
  Real inv_tan{};                         //!< 1 / tan(alpha)
  int64_t fx_q16 = 0;                     //!< fx in Q16.16 (integer comparison Delta fx > T* z_n)
  int cell_w = 0, cell_h = 0;             //!< cell size in pixels (the last cells may be smaller or empty)
  int64_t bound_q16[kGrid * kGrid] = {};  //!< per cell, row-major: lower bound of T*, Q16.16
  bool prepared = false;                  //!< prepare() succeeded

  //! \param params threshold
  //! \param intr intrinsics of the depth images that will be filtered
  //! \return kInvalidArgument when params or intrinsics are invalid
  Status prepare(const JumpEdgeParams& params, const PinholeIntrinsics& intr);
};

//! out = depth with jump-edge pixels set to 0. Not in place: every decision reads the unfiltered
//! neighbours, so out must not overlap depth.
//! \param depth raw z-depth, 0 = invalid, size = the kernel's intrinsics
//! \param kernel prepared constants
//! \param out filtered depth, same size
//! \return kNotInitialised before prepare(); kInvalidArgument on size mismatch, empty views or overlap
template <class Real>
Status remove_jump_edges(ImageView<const uint16_t> depth, const JumpEdgeKernel<Real>& kernel, ImageView<uint16_t> out);

}  // namespace edgefuse
