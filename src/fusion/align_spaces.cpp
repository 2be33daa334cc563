#include "edgefuse/fusion/align_spaces.hpp"

namespace edgefuse {

template <class Real>
Status align_spaces(const TsdfVolume& model, const TsdfVolume& other, const PinholeIntrinsics& view_intr,
                    const Pose& T_model_view, const Pose& T_model_other_guess, FramePyramid<Real>& pyramid,
                    const RaycastMaps& model_maps, const RaycastMaps& other_maps, ImageView<uint16_t> depth_scratch, const IcpWorkspace<Real>& ws,
                    const PairCalibrationParams& params, int outer_rounds, PairCalibrationResult& out) {
  out = PairCalibrationResult{};
  out.T_a_b = T_model_other_guess;
  if (outer_rounds < 1 || depth_scratch.empty() || depth_scratch.width != view_intr.width ||
      depth_scratch.height != view_intr.height)
    return Status::kInvalidArgument;
  Pose T = T_model_other_guess;
  for (int round = 0; round < outer_rounds; ++round) {
    // The other space as a sensor at V would see it, if T were right.
    Status s = raycast<Real>(other, view_intr, T.inverse() * T_model_view, other_maps);
    if (s != Status::kOk) return s;
    for (int v = 0; v < view_intr.height; ++v)
      for (int u = 0; u < view_intr.width; ++u) {
        const float raw = other_maps.depth_m.at(u, v) * view_intr.depth_scale + 0.5f;
        depth_scratch.at(u, v) = other_maps.depth_m.at(u, v) > 0.0f && raw < 65535.0f ? uint16_t(raw) : uint16_t(0);
      }
    s = build_pyramid<Real>(depth_scratch, PyramidParams(), pyramid);
    if (s != Status::kOk) return s;
    // The depth map is a frame taken at V: its pose relative to V is the correction.
    PairCalibrationResult r;
    s = calibrate_pair<Real>(model, T_model_view, Pose::identity(), view_intr, pyramid, model_maps, ws,
                             params, r);
    if (s != Status::kOk) return s;
    T = T_model_view * r.T_a_b * T_model_view.inverse() * T;
    out = r;
    out.T_a_b = T;
    if (!r.accepted) return Status::kOk;
  }
  return Status::kOk;
}

#define EDGEFUSE_INSTANTIATE(Real)                                                                                  \
  template Status align_spaces<Real>(const TsdfVolume&, const TsdfVolume&, const PinholeIntrinsics&, const Pose&,   \
                                     const Pose&, FramePyramid<Real>&, const RaycastMaps&,                          \
                                     const RaycastMaps&, ImageView<uint16_t>,                                       \
                                     const IcpWorkspace<Real>&, const PairCalibrationParams&, int,                  \
                                     PairCalibrationResult&);
EDGEFUSE_INSTANTIATE(float)
EDGEFUSE_INSTANTIATE(Fixed)
#undef EDGEFUSE_INSTANTIATE

}  // namespace edgefuse
