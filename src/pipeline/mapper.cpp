#include "edgefuse/pipeline/mapper.hpp"

#include "edgefuse/fusion/fusion_rules.hpp"
#include "edgefuse/tracking/pyramid.hpp"
#include "edgefuse/tsdf/integrate_profile.hpp"

namespace edgefuse {

Status Mapper::init(TsdfVolume& volume, const KernelRunners& runners, ImageView<uint16_t> filter_spare,
                    const ViewCentreScratch& centre, const MapperParams& params) {
  if (!params.tracker.valid() || centre.capacity == 0) return Status::kInvalidArgument;
  volume_ = &volume;
  runners_ = runners;
  filter_spare_ = filter_spare;
  centre_ = centre;
  params_ = params;
  fused_count_ = 0;
  new_map();
  return Status::kOk;
}

void Mapper::set_fused_cameras(CameraSlot* const* cameras, int count) {
  fused_count_ = count < kFusedMax ? count : kFusedMax;
  for (int k = 0; k < fused_count_; ++k) fused_[k] = cameras[k];
}

void Mapper::new_map() {
  centre_pending_ = true;
  map_frames_ = 0;
  view_sum_ = Vec3f::Zero();
  history_.clear();
}

void Mapper::new_map_in_place() {
  new_map();
  centre_pending_ = false;
}

// Filters and weights one camera frame into `out` (the camera's filtered image and trust map).
Status Mapper::prepare_frame(CameraSlot& cam, const SensorFrame& in, DepthFrame& out, bool* filtered) {
  float sigma_m = 0.0f;
  const Status s = weigh_frame(cam, in, out, sigma_m, filtered);
  if (s != Status::kOk || !params_.noise_weights) return s;
  // The fusion rules (fusion_rules.hpp): the depth-jump limit follows the frame's median modelled
  // noise; the sub-unit fill is decided from the medians so far, this frame's included, so a
  // sub-unit camera's frames all take it.
  cam.sigma.add(sigma_m);
  if (params_.rules.jump_sigmas > 0.0f) {
    out.jump_m = noise_jump_m(sigma_m, params_.rules.jump_sigmas);
    cam.counts.jump_m_sum += out.jump_m;
    ++cam.counts.jump_frames;
  }
  out.sub_unit_fill_units = sub_unit_fill();
  return Status::kOk;
}

// The pre-filters and, with noise weights, the trust map and noise gate; sigma_m: the frame's median
// modelled noise (of the pixels the gate keeps). Counts nothing.
Status Mapper::weigh_frame(CameraSlot& cam, const SensorFrame& in, DepthFrame& out, float& sigma_m, bool* filtered) {
  out = DepthFrame();
  out.depth = in.depth;
  const int w = in.depth.width, h = in.depth.height;
  const bool gate = params_.noise_weights && params_.rules.noise_gate_m > 0.0f;
  if (params_.prefilter) {
    const Status s = cam.filter(in, filter_spare_);
    if (s != Status::kOk) return s;
    out.depth = ImageView<const uint16_t>(cam.filtered.data, w, h);
  } else if (gate) {  // the gate drops pixels: a copy to drop them from
    for (int i = 0; i < w * h; ++i) cam.filtered.data[i] = in.depth.data[i];
    out.depth = ImageView<const uint16_t>(cam.filtered.data, w, h);
  }
  if (filtered != nullptr) *filtered = true;
  out.colour = in.colour;
  if (params_.rules.sub_unit_fill_units > 0) out.sub_unit_fill_units = params_.rules.sub_unit_fill_units;
  sigma_m = 0.0f;
  if (!params_.noise_weights) return Status::kOk;
  const Status s = build_trust_map(cam.noise, 0.5f * volume_->voxel_m(), out.depth, cam.intr.depth_scale, in.amplitude,
                                   cam.trust, params_.rules.noise_gate_m, &sigma_m);
  if (s != Status::kOk) return s;
  out.trust = cam.trust;
  if (gate) apply_noise_gate(cam, out);
  return Status::kOk;
}

// A pixel the gate refused (trust 0) carves no free space either: its depth is dropped.
void Mapper::apply_noise_gate(CameraSlot& cam, const DepthFrame& f) {
  uint16_t* depth = cam.filtered.data;
  const int n = f.depth.width * f.depth.height;
  for (int i = 0; i < n; ++i) {
    if (depth[i] == 0) continue;
    ++cam.counts.pixels;
    if (f.trust.data[i] != 0) continue;
    ++cam.counts.gated_pixels;
    depth[i] = 0;
  }
}

Status Mapper::measure_noise(CameraSlot& cam, const SensorFrame& frame, float& sigma_m) {
  DepthFrame f;
  const CameraSlot::MapCounts before = cam.counts;
  const Status s = weigh_frame(cam, frame, f, sigma_m, nullptr);
  cam.counts = before;
  return s;
}

Status Mapper::map_reference(CameraSlot& cam, const SensorFrame& in, const Pose* known, const Pose& start,
                             ReferenceStep& out, StepObserver* observer) {
  out = ReferenceStep();
  DepthFrame f;
  Status s = prepare_frame(cam, in, f, &out.filtered);
  if (observer != nullptr) observer->phase_done(MapPhase::kFilter);
  if (s != Status::kOk) return s;
  if (params_.poses != PoseMode::kTracked && known == nullptr) {
    history_.clear();  // no pose: nothing can be paired with this frame
    return Status::kOk;
  }
  if (params_.poses == PoseMode::kKnown) {
    out.T_world_cam = *known;
    out.has_pose = true;
    out.track.T_world_cam = *known;
    out.track.push = true;
    out.track.first = map_frames_ == 0;
  } else {
    // kPrior: a new map starts at the first frame's prior, every frame is aligned from its own prior.
    const Pose* prior = params_.poses == PoseMode::kPrior ? known : nullptr;
    s = track(cam, f, prior != nullptr ? *prior : start, prior, out, observer);
    if (s != Status::kOk) return s;
  }
  history_.record(in.stamp_us, out.T_world_cam, out.has_pose);
  if (!out.track.push) return Status::kOk;
  if (centre_pending_) out.centred = centre_on(cam, f, out.T_world_cam);
  if (centre_pending_) return Status::kOk;  // nothing in range to place a new map on: not integrated
  s = integrate_at(cam, f, out.T_world_cam);
  if (observer != nullptr) observer->phase_done(MapPhase::kIntegrate);
  if (s != Status::kOk) return s;
  out.integrated = true;
  last_capture_us_ = in.stamp_us;
  return Status::kOk;
}

// The paper's loop (Fig. 3): ICP of the frame against the model raycast at the last good pose, or
// with a prior (robot+icp) at the prior. A new map starts at `start`; its first frame is pushed
// there without alignment.
Status Mapper::track(CameraSlot& cam, const DepthFrame& f, const Pose& start, const Pose* prior, ReferenceStep& out,
                     StepObserver* observer) {
  const bool first = starts_new_map();
  if (first) {
    const Status s = tracker_.start(start, params_.tracker, true);
    if (s != Status::kOk) return s;
    if (centre_pending_) out.centred = centre_on(cam, f, start);
  }
  Status s = Status::kOk;
  const Pose& model_pose = prior != nullptr ? *prior : tracker_.raycast_pose();
  if (!first) s = raycast_frame<real_t>(runners_.tsdf, *volume_, cam.intr, model_pose, cam.maps);
  if (observer != nullptr) observer->phase_done(MapPhase::kRaycast);
  if (s == Status::kOk) s = build_pyramid<real_t>(f.depth, PyramidParams(), cam.pyramid);
  if (s == Status::kOk && prior != nullptr)
    s = tracker_.track_prior<real_t>(*prior, cam.pyramid, cam.maps, cam.intr, cam.icp_ws, out.track, runners_.icp);
  else if (s == Status::kOk)
    s = tracker_.track<real_t>(cam.pyramid, cam.maps, cam.intr, cam.icp_ws, out.track, runners_.icp);
  if (observer != nullptr) observer->phase_done(MapPhase::kTrack);
  if (s != Status::kOk) return s;
  out.T_world_cam = out.track.T_world_cam;
  out.has_pose = out.track.state != TrackState::kLost;
  return Status::kOk;
}

Status Mapper::align_reference(CameraSlot& cam, const SensorFrame& in, const Pose& prior, TrackResult& out) {
  out = TrackResult{};
  if (centre_pending_ || map_frames_ == 0) return Status::kNotInitialised;
  DepthFrame f;
  float sigma_m = 0.0f;
  const CameraSlot::MapCounts before = cam.counts;  // aligning is not mapping: nothing counted
  Status s = weigh_frame(cam, in, f, sigma_m, nullptr);
  cam.counts = before;
  if (s == Status::kOk) s = raycast_frame<real_t>(runners_.tsdf, *volume_, cam.intr, prior, cam.maps);
  if (s == Status::kOk) s = build_pyramid<real_t>(f.depth, PyramidParams(), cam.pyramid);
  if (s == Status::kOk) s = tracker_.align_prior<real_t>(prior, cam.pyramid, cam.maps, cam.intr, cam.icp_ws, out, runners_.icp);
  return s;
}

// Centres the volume on the frame's view and clears it; stays pending when the frame sees nothing.
bool Mapper::centre_on(const CameraSlot& cam, const DepthFrame& f, const Pose& T_world_cam) {
  Vec3f centre;
  if (view_centre(cam.intr, f.depth, T_world_cam, centre_, centre) == 0) return false;
  volume_->set_origin(volume_origin_for(centre, volume_->dim(), volume_->voxel_m()));
  volume_->clear();
  centre_pending_ = false;
  return true;
}

Status Mapper::map_at(CameraSlot& cam, const SensorFrame& in, const Pose& T_world_cam) {
  if (centre_pending_) return Status::kNotInitialised;
  DepthFrame f;
  const Status s = prepare_frame(cam, in, f, nullptr);
  return s == Status::kOk ? integrate_at(cam, f, T_world_cam) : s;
}

Status Mapper::map_paired(CameraSlot& cam, const SensorFrame& in, const Pose& T_ref_cam) {
  if (centre_pending_ || !history_.has_pose()) return Status::kNotInitialised;
  return map_at(cam, in, history_.pose_at(in.stamp_us) * T_ref_cam);
}

// Integrates a prepared frame and counts it into the map.
Status Mapper::integrate_at(CameraSlot& cam, const DepthFrame& f, const Pose& T_world_cam) {
  const Status s = integrate_frame<real_t>(runners_.tsdf, *volume_, cam.intr, cam.ray_norms, f, T_world_cam, cam.scratch);
  if (s != Status::kOk) return s;
  ++map_frames_;
  view_sum_ += T_world_cam.t;
  return Status::kOk;
}

Status Mapper::map_profile(const LineScannerModel& model, const LineScannerTables<real_t>& tables,
                           const float* ranges_m, const Pose& T_world_sensor, float sigma_m) {
  if (centre_pending_) return Status::kNotInitialised;
  // Not capped at one camera sample (kProfileTrustMax): a fine scanner must be able to outweigh an
  // average of many coarser camera samples on its strip. Without noise weights every sample is a full one.
  const float trust = params_.noise_weights
                          ? NoiseModel::constant(sigma_m).trust(0.5f * volume_->voxel_m(), 0.0f, 0.0f, kProfileTrustMax)
                          : 1.0f;
  return integrate_profile<real_t>(*volume_, model, tables, ranges_m, T_world_sensor, 0.0f, trust);
}

void Mapper::fused_sigmas(float (&sigma)[kFusedMax]) const {
  for (int k = 0; k < kFusedMax; ++k) sigma[k] = k < fused_count_ ? fused_[k]->median_sigma() : 0.0f;
}

int Mapper::sub_unit_fill() const {
  if (params_.rules.sub_unit_fill_units > 0) return params_.rules.sub_unit_fill_units;
  float sigma[kFusedMax];
  fused_sigmas(sigma);
  return default_sub_unit_fill(sigma, fused_count_, 0.5f * volume_->voxel_m());
}

uint8_t Mapper::support_weight() const {
  if (!params_.noise_weights) return 0;  // one camera, equal weights: every observed crossing
  float sigma[kFusedMax];
  fused_sigmas(sigma);
  return default_support_weight(sigma, fused_count_, 0.5f * volume_->voxel_m(), sub_unit_fill());
}

}  // namespace edgefuse
