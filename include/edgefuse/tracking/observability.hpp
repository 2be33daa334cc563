// Which of the six pose directions a view constrains: decided once per frame from the raycast model
// (the view at the last good pose), before the ICP iterates.
//
// Each square tile of the model maps contributes one averaged point p and unit normal n, weighted
// by its valid pixels, to A = sum c J^T J with J = [p x n, n]. A is scaled like the ICP system
// (rotation columns divided by the mean depth L, so both halves are in metres at that depth) and
// eigen-decomposed (fixed size). Directions whose eigenvalue is at least min_eigen_ratio of the
// largest are observable; the ICP updates only in those, the others keep the prediction.
//
// Why tile averages and not the per-pixel system: sensor noise makes per-pixel TSDF normals
// scatter by a few degrees, and on a plane that lends the three unobservable directions
// eigenvalues of (normal noise)^2, measured 2e-4 .. 3e-3 of the largest (1.5-3 mm depth noise,
// 5-10 mm voxels) -- as large as a real but weak constraint (the bin_rig_a walls holding the
// rotation about the view axis: ~1e-3). Averaging over tiles of 32 pixels (at 320 wide) takes the
// plane's noise directions below 6e-5 while keeping every structure larger than a tile.
#pragma once

#include "edgefuse/core/status.hpp"
#include "edgefuse/tracking/icp_solve.hpp"
#include "edgefuse/tsdf/raycast.hpp"

namespace edgefuse {

struct ViewObservability {
  Mat6f basis = Mat6f::Identity();  //!< eigenvectors (columns, scaled space), ascending eigenvalues
  bool observable[6] = {};           //!< per column of basis
  int count = 0;                     //!< observable directions
  float weakest_ratio = 0;           //!< smallest eigenvalue / largest
  float scale_m = 1;                 //!< mean depth L of the view (rotation scale)
};

//! \param model raycast maps (vertex, normal)
//! \param tile_px tile edge in pixels (>= 1)
//! \param min_eigen_ratio eigenvalue fraction of the largest for a direction to be observable
//! \param out result (count = 0 when the view holds no surface)
Status view_observability(const RaycastMaps& model, int tile_px, float min_eigen_ratio, ViewObservability& out);

}  // namespace edgefuse
