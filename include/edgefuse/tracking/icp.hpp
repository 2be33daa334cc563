// Point-to-plane ICP of a new frame against the raycast model (paper Fig. 3, "T_icp <- ICP(model,
// scene)"), projective data association, coarse to fine over the frame's pyramid.
//
// Frames: the model maps are in the sensor frame of the raycast pose ("model frame"); the result
// T_model_frame maps the new frame's points into it, so the new pose is T_world_model T_model_frame.
// Working in the model frame keeps coordinates within the sensor's range (good conditioning, and
// Q16.16 never sees world-sized numbers).
//
// One evaluation, per frame point p with a normal (pixel order fixed: row by row, left to right):
//   p_m = T p; pixel = nearest to project(p_m) with the sensor's full-resolution intrinsics (coarse
//   levels look up the full-resolution model directly: no subsampled model copy is needed, and the
//   model point is the one the coarse point actually projects onto); q, n = model vertex / normal
//   there; rejected when the model has no normal, |p_m - q| > max_distance_m, or the rotated frame
//   normal is more than max_normal_angle_deg from n;
//   r = n . (p_m - q);  with exp(xi) p_m ~ p_m + omega x p_m + v,
//   r(xi) ~ r + n . (omega x p_m) + n . v = r + (p_m x n) . omega + n . v, so the Jacobian row is
//   J = [ (p_m x n)^T, n^T ] for xi = (omega, v). (Not n x p_m: that flips the rotation's sign,
//   the typo the authors' library had.) Robust weight w(r) (Huber or Tukey).
// Then A = sum w J^T J, b = sum w J^T r, solved for xi = -A^-1 b in the directions the view
// observes (decided once per frame from the model, observability.hpp; the step in the others is
// zero, icp_solve.hpp), T <- exp(xi) T, re-orthonormalised. A level ends after its iteration count or
// when |omega| and |v| fall below the stop thresholds.
//
// Accumulation (deterministic, and exact enough in both numeric builds):
//   float: each row's sums in float (<= 640 terms of similar size: relative error ~1e-5), rows
//          added in row order in double;
//   Fixed: products of Q16.16 raws are Q32.32 and summed exactly in int64 (|J| <= |p_m| <= 10 m,
//          < 2^19 pixels: below 2^58, no overflow), then scaled to float once per iteration.
// The per-row partial sums live in a caller buffer (IcpWorkspace); rows may be evaluated on any
// number of threads (RowRunner) and are always reduced in row order, so threads never change the
// result.
#pragma once

#include <cstddef>
#include <cstdint>

#include "edgefuse/core/row_runner.hpp"
#include "edgefuse/core/status.hpp"
#include "edgefuse/math/pose.hpp"
#include "edgefuse/math/real.hpp"
#include "edgefuse/tracking/observability.hpp"
#include "edgefuse/tracking/pyramid.hpp"
#include "edgefuse/tsdf/raycast.hpp"

namespace edgefuse {

enum class RobustLoss : uint8_t {
  kNone,   //!< least squares
  kHuber,  //!< w = 1 for |r| <= k, k / |r| beyond (k = robust_scale_m)
  kTukey,  //!< w = (1 - (r / c)^2)^2 for |r| < c, 0 beyond (c = robust_scale_m)
};

struct IcpParams {
  //! Gauss-Newton iterations per pyramid level, index 0 = full resolution (KinectFusion's 10 / 5 /
  //! 4 for full / half / quarter). Levels run coarse to fine; each may stop early on update size.
  //! 0 skips a level.
  int iterations[kPyramidLevels] = {10, 5, 4};
  //! Correspondences farther apart than this are rejected. Default 0.05 m: ten times the
  //! structured-light noise at 1.5 m, and well above a frame's motion at 30 Hz for a hand or a
  //! gripper (< 1.5 m/s), yet a 30 cm jump finds almost no partner.
  float max_distance_m = 0.05f;
  //! Correspondences whose normals differ by more than this are rejected. Default 30 degrees: the
  //! frame's normals come from raw pixel neighbours and scatter by 10-20 degrees on Kinect-class
  //! depth at full resolution; opposite faces of thin objects are still told apart.
  float max_normal_angle_deg = 30.0f;
  //! Robust weighting of the point-to-plane residual. Default Huber: keeps every inlier's
  //! information and bounds the pull of outliers linearly.
  RobustLoss loss = RobustLoss::kHuber;
  //! Huber k / Tukey c in metres. Default 0.005 m: about 1.5 x the structured-light noise at
  //! 1-1.5 m (the usual 1.345 sigma of Huber's 95 % efficiency), 3 x at the bin's 0.7 m.
  float robust_scale_m = 0.005f;
  //! Directions whose eigenvalue in the view's observability system is below this fraction of
  //! the largest are not updated (observability.hpp). Default 1e-4. The ratio is roughly the share
  //! of the points that pin a direction down fully. Measured: a plane's unobservable directions
  //! <= 6e-5 even with 3 mm depth noise on 5 mm voxels (1e-6 noise-free); the weakest real
  //! directions 2e-4 (bin_rig_a ToF, 160x120), 1.3e-3 (bin_rig_a xtion), 8.6e-3 (TUM fr1/xyz).
  float min_eigen_ratio = 1e-4f;
  //! Tiles across the image width for the observability system (square tiles of width / this
  //! pixels: 32 at 320, 64 at 640). Default 10: tiles span several voxel footprints, so the normal
  //! noise averages out, and still resolve a bin's walls and objects.
  int observability_tiles = 10;
  //! Fewer observable directions than this refuse the frame (no update). Default 3: a single
  //! plane gives exactly 3 (distance, two tilts) and is still corrected in those; fewer means the
  //! view holds almost nothing.
  int min_observable = 3;
  //! Fewer inliers than this refuse the system. Default 100 (a 40x30 quarter-resolution image has
  //! 1200 pixels; 100 still over-determines 6 unknowns many times).
  int min_correspondences = 100;
  //! A level stops when the update's translation is below this. Default 1e-5 m (0.01 mm).
  float stop_translation_m = 1e-5f;
  //! ... and its rotation below this. Default 1e-5 rad (0.0006 degrees).
  float stop_rotation_rad = 1e-5f;

  //! Positive thresholds, iterations >= 0 (>= 1 at full resolution), eigen ratio in (0, 1),
  //! 1 <= min_observable <= 6, observability_tiles >= 1.
  bool valid() const;
};

struct IcpStats {
  int iterations[kPyramidLevels] = {};  //!< iterations run per level
  int valid_points = 0;     //!< full-resolution frame points with depth and normal
  int candidates = 0;       //!< of those, points projecting onto model surface with a compatible normal
  int correspondences = 0;  //!< of those, inliers (distance; Tukey) of the last full-resolution evaluation
  float rms_m = 0;          //!< point-to-plane RMS of those inliers (unweighted)
  int observable = 0;       //!< directions the view constrains (6 = all), updated by the ICP
  float weakest_ratio = 0;  //!< smallest eigenvalue / largest of the view's observability system
  bool converged = false;   //!< the full-resolution level stopped on update size
  bool refused = false;     //!< no usable full-resolution system (too few inliers, too few observable
                            //!< directions, or the inliers do not support an observable one)

  //! correspondences / candidates: how well the frame agrees with the model where both see a
  //! like-oriented surface (0 when nothing overlaps). Neither model coverage (new surface, the
  //! space's border) nor noisy frame normals lower it; a misaligned frame's points land far from
  //! the model surface they project onto.
  float inlier_ratio() const { return candidates > 0 ? float(correspondences) / float(candidates) : 0.0f; }
  //! candidates / valid_points: how much of the frame the model covers.
  float coverage() const { return valid_points > 0 ? float(candidates) / float(valid_points) : 0.0f; }
};

//! Per-row partial sums of one evaluation (Acc = float for the float kernels, int64 Q32.32 for Fixed).
template <class Acc>
struct IcpSums {
  Acc ata[21] = {};  //!< upper triangle of sum w J^T J, row-major
  Acc atb[6] = {};   //!< sum w J^T r
  Acc rr = {};       //!< sum r^2 over inliers (unweighted)
  int32_t count = 0;      //!< inliers
  int32_t valid = 0;      //!< frame points with depth and normal
  int32_t candidates = 0; //!< frame points projecting onto model surface with a compatible normal
};

//! The per-row sums type of a kernel scalar.
template <class Real>
struct IcpAccumulator;
template <>
struct IcpAccumulator<float> {
  using Row = IcpSums<float>;
};
template <>
struct IcpAccumulator<Fixed> {
  using Row = IcpSums<int64_t>;
};

//! Bytes of one row's partial sums, the larger of the two builds' (memory map sizing).
inline constexpr std::size_t kIcpRowBytes =
    sizeof(IcpSums<int64_t>) > sizeof(IcpSums<float>) ? sizeof(IcpSums<int64_t>) : sizeof(IcpSums<float>);

//! Caller storage for the per-row partial sums: one per row of the largest image.
template <class Real>
struct IcpWorkspace {
  typename IcpAccumulator<Real>::Row* rows = nullptr;  //!< one per image row
  int capacity = 0;                                     //!< rows it holds

  //! Views `bytes` of static storage (aligned for int64) as row sums.
  //! \param storage start  \param bytes size
  static IcpWorkspace bind(void* storage, std::size_t bytes) {
    IcpWorkspace w;
    w.rows = static_cast<typename IcpAccumulator<Real>::Row*>(storage);
    w.capacity = int(bytes / sizeof(typename IcpAccumulator<Real>::Row));
    return w;
  }
};

//! Aligns the frame to the model.
//! \param frame the new frame's pyramid (build_pyramid)
//! \param model raycast maps (vertex and normal required) at the model pose, sensor-sized
//! \param intr the sensor's full-resolution intrinsics (the model maps' size)
//! \param T_init initial T_model_frame (identity: the frame was taken at the raycast pose)
//! \param params thresholds
//! \param ws per-row sums, at least intr.height rows
//! \param T_model_frame result (T_init when nothing could be aligned)
//! \param stats what happened
//! \param runner optional row runner (threads); the result does not depend on it
template <class Real>
Status icp_align(const FramePyramid<Real>& frame, const RaycastMaps& model, const PinholeIntrinsics& intr,
                 const Pose& T_init, const IcpParams& params, const IcpWorkspace<Real>& ws, Pose& T_model_frame,
                 IcpStats& stats, const RowRunner* runner = nullptr);

}  // namespace edgefuse
