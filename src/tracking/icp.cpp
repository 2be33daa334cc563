#include "edgefuse/tracking/icp.hpp"

#include <cmath>

#include "edgefuse/tracking/icp_solve.hpp"
#include "edgefuse/tracking/se3.hpp"
#include "icp_rows.hpp"

namespace edgefuse {

bool IcpParams::valid() const {
  for (int k = 0; k < kPyramidLevels; ++k)
    if (iterations[k] < 0) return false;
  return iterations[0] >= 1 && max_distance_m > 0.0f && max_normal_angle_deg > 0.0f &&
         max_normal_angle_deg <= 180.0f && robust_scale_m > 0.0f && min_eigen_ratio > 0.0f &&
         min_eigen_ratio < 1.0f && observability_tiles >= 1 && min_observable >= 1 && min_observable <= 6 &&
         min_correspondences >= 6 &&
         stop_translation_m >= 0.0f && stop_rotation_rad >= 0.0f;
}

namespace {

template <class Real>
void rows_thunk(void* job, int begin, int end) {
  icp_rows(*static_cast<const IcpPass<Real>*>(job), begin, end);
}

// Row sums -> float system, rows added in order: float rows in double, Fixed rows exactly in int64
// (Q32.32, hence the scale). Acc is the accumulator type, Sum the row type's element.
template <class Acc, class Sum>
void reduce_rows(const IcpSums<Sum>* rows, int n, float scale, IcpSystem& s) {
  Acc ata[21] = {}, atb[6] = {}, rr = 0;
  long count = 0, valid = 0, candidates = 0;
  for (int v = 0; v < n; ++v) {
    for (int k = 0; k < 21; ++k) ata[k] += rows[v].ata[k];
    for (int k = 0; k < 6; ++k) atb[k] += rows[v].atb[k];
    rr += rows[v].rr;
    count += rows[v].count;
    valid += rows[v].valid;
    candidates += rows[v].candidates;
  }
  int k = 0;
  for (int i = 0; i < 6; ++i)
    for (int j = i; j < 6; ++j) s.A(i, j) = s.A(j, i) = float(ata[k++]) * scale;
  for (int i = 0; i < 6; ++i) s.b(i) = float(atb[i]) * scale;
  s.rr = float(rr) * scale;
  s.count = int(count);
  s.valid = int(valid);
  s.candidates = int(candidates);
}

void reduce(const IcpSums<float>* rows, int n, IcpSystem& s) { reduce_rows<double>(rows, n, 1.0f, s); }

void reduce(const IcpSums<int64_t>* rows, int n, IcpSystem& s) {
  reduce_rows<int64_t>(rows, n, 1.0f / 4294967296.0f, s);  // Q32.32 -> value
}

template <class Real>
void set_pose(IcpPass<Real>& pass, const Pose& T) {
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) pass.R[r * 3 + c] = real_from<Real>(T.R(r, c));
    pass.t[r] = real_from<Real>(T.t(r));
  }
}

template <class Real>
void evaluate(IcpPass<Real>& pass, const RowRunner* runner, IcpSystem& s) {
  const int rows = pass.level->intr.height;
  if (runner != nullptr && runner->run != nullptr)
    runner->run(runner->self, &rows_thunk<Real>, &pass, rows);
  else
    icp_rows(pass, 0, rows);
  reduce(pass.rows, rows, s);
}

}  // namespace

template <class Real>
Status icp_align(const FramePyramid<Real>& frame, const RaycastMaps& model, const PinholeIntrinsics& intr,
                 const Pose& T_init, const IcpParams& params, const IcpWorkspace<Real>& ws, Pose& T_model_frame,
                 IcpStats& stats, const RowRunner* runner) {
  stats = IcpStats{};
  T_model_frame = T_init;
  if (!params.valid() || intr.validate() != Status::kOk) return Status::kInvalidArgument;
  if (model.vertex.empty() || model.normal.empty() || model.vertex.width != intr.width ||
      model.vertex.height != intr.height || model.normal.width != intr.width || model.normal.height != intr.height)
    return Status::kInvalidArgument;
  if (frame.level[0].intr.width != intr.width || frame.level[0].intr.height != intr.height ||
      frame.level[0].vertex.empty())
    return Status::kInvalidArgument;
  if (ws.rows == nullptr || ws.capacity < intr.height) return Status::kCapacityExceeded;

  IcpPass<Real> pass;
  pass.fx = real_from<Real>(intr.fx);
  pass.fy = real_from<Real>(intr.fy);
  pass.cx = real_from<Real>(intr.cx);
  pass.cy = real_from<Real>(intr.cy);
  pass.min_z = real_from<Real>(0.5f * intr.min_range_m > 0.01f ? 0.5f * intr.min_range_m : 0.01f);
  pass.max_dist2 = real_from<Real>(params.max_distance_m * params.max_distance_m);
  pass.min_cos = real_from<Real>(std::cos(params.max_normal_angle_deg * float(M_PI) / 180.0f));
  pass.robust_scale = real_from<Real>(params.robust_scale_m);
  pass.loss = params.loss;
  pass.model_w = intr.width;
  pass.model_h = intr.height;
  pass.model_vertex = model.vertex;
  pass.model_normal = model.normal;
  pass.rows = ws.rows;

  // The directions this view constrains, once per frame (the model does not change meanwhile).
  ViewObservability view;
  const int tile = intr.width / params.observability_tiles > 0 ? intr.width / params.observability_tiles : 1;
  const Status vs = view_observability(model, tile, params.min_eigen_ratio, view);
  if (vs != Status::kOk) return vs;
  stats.observable = view.count;
  stats.weakest_ratio = view.weakest_ratio;
  const bool observable = view.count >= params.min_observable;

  Pose T = T_init;
  for (int level = kPyramidLevels - 1; level >= 0; --level) {
    pass.level = &frame.level[level];
    for (int it = 0; it < params.iterations[level]; ++it) {
      set_pose(pass, T);
      IcpSystem sys;
      evaluate(pass, runner, sys);
      stats.iterations[level] = it + 1;
      if (level == 0) {
        stats.valid_points = sys.valid;
        stats.candidates = sys.candidates;
        stats.correspondences = sys.count;
        stats.rms_m = sys.count > 0 ? std::sqrt(sys.rr / float(sys.count)) : 0.0f;
      }
      Vec6f xi;
      const bool usable = observable && sys.count >= params.min_correspondences && solve_icp_step(sys, view, xi);
      if (level == 0) stats.refused = !usable;
      if (!usable) break;  // keep the pose: a coarser level's result, or the start
      T = se3_exp(xi) * T;
      T.R = orthonormalise(T.R);
      if (xi.head<3>().norm() < params.stop_rotation_rad && xi.tail<3>().norm() < params.stop_translation_m) {
        if (level == 0) stats.converged = true;
        break;
      }
    }
  }
  T_model_frame = T;
  return Status::kOk;
}

template Status icp_align<float>(const FramePyramid<float>&, const RaycastMaps&, const PinholeIntrinsics&, const Pose&,
                                 const IcpParams&, const IcpWorkspace<float>&, Pose&, IcpStats&, const RowRunner*);
template Status icp_align<Fixed>(const FramePyramid<Fixed>&, const RaycastMaps&, const PinholeIntrinsics&, const Pose&,
                                 const IcpParams&, const IcpWorkspace<Fixed>&, Pose&, IcpStats&, const RowRunner*);

}  // namespace edgefuse
