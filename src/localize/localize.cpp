// Model-based localisation: vote, cluster the candidates of each model, refine the best clusters by
// point-to-plane ICP, verify them, then keep the best non-overlapping hypotheses in picking order.
#include <algorithm>
#include <cmath>

#include "edgefuse/localize/localizer.hpp"
#include "edgefuse/math/real.hpp"
#include "pose_order.hpp"
#include "ppf_math.hpp"

namespace edgefuse {
namespace {

struct Cluster {
  Pose T;
  float votes;
  uint32_t first;  // index of its best candidate (ties: earlier first)
};

// At most this many model samples take part in ICP and verification (even stride over the table).
constexpr uint32_t kIcpPoints = 1500;
constexpr uint32_t kRefinePoints = 1500;  // ICP needs fewer than the verification

}  // namespace

bool Localizer::observable(const Vec3f& q, const Vec3f& n, float cos_max_incidence) const {
  const Vec3f v = ctx_.viewpoint_m - q;
  return n.dot(v) > cos_max_incidence * v.norm();
}

namespace {
float cos_deg(float deg) { return std::cos(deg * (ppf::kPi / 180.0f)); }
}  // namespace

bool Localizer::plausible(int m, const Pose& T, const LocalizeParams& params) const {
  const float cos_inc = cos_deg(params.max_incidence_deg);
  // Share of ~100 facing samples with a scene point within two PPF steps: far below the final
  // threshold means ICP cannot rescue the pose.
  const ModelInfo& info = b_.models[m];
  const OrientedPoint* dense = model_points(m);
  const uint32_t stride = info.dense_count > 100 ? info.dense_count / 100 : 1;
  uint32_t facing = 0, near = 0;
  const float r = std::max(2.0f * info.ppf_step_m, 2.0f * params.support_tol_m);
  for (uint32_t i = 0; i < info.dense_count; i += stride) {
    const Vec3f q = T * dense[i].p;
    if (!observable(q, T.R * dense[i].n, cos_inc)) continue;
    ++facing;
    float d2;
    near += nearest(q, r, d2) >= 0;
  }
  return facing > 0 && float(near) >= 0.5f * params.min_score * float(facing);
}

bool Localizer::refine(int m, Pose& T, const LocalizeParams& params) const {
  const float cos_inc = cos_deg(params.max_incidence_deg);
  const ModelInfo& info = b_.models[m];
  const OrientedPoint* dense = model_points(m);
  // Coarse to fine: the first iterations (large gate) use a quarter of the samples.
  const uint32_t fine = info.dense_count > kRefinePoints ? (info.dense_count + kRefinePoints - 1) / kRefinePoints : 1;
  float radius = std::max(2.0f * info.ppf_step_m, 0.01f);
  const float radius_min = std::max(2.0f * params.support_tol_m, 1.5f * grid_cell_m_ * 0.5f);
  for (int it = 0; it < params.icp_iterations; ++it) {
    const uint32_t stride = it < params.icp_iterations / 2 ? 4 * fine : fine;
    Eigen::Matrix<float, 6, 6> A = Eigen::Matrix<float, 6, 6>::Zero();
    Eigen::Matrix<float, 6, 1> rhs = Eigen::Matrix<float, 6, 1>::Zero();
    const Vec3f c = T * info.centre_m;
    int used = 0;
    for (uint32_t i = 0; i < info.dense_count; i += stride) {
      const Vec3f q = T * dense[i].p;
      const Vec3f n = T.R * dense[i].n;
      if (n.dot(ctx_.viewpoint_m - q) <= 0) continue;  // faces away from the sensor
      float d2;
      const int32_t j = nearest(q, radius, d2);
      if (j < 0) continue;
      const ScenePoint& s = b_.scene[j];
      // Model surface the sensor sees at grazing incidence only pairs with scene surface of nearly
      // the same orientation: otherwise it latches onto the rounded edges of the fused surface
      // (normals half-way between two faces) and drags thin parts sideways.
      if (n.dot(s.n) < (observable(q, n, cos_inc) ? 0.7f : 0.85f)) continue;  // 0.85: bin_rig_a median 0.22 mm (0.95 lost a box of test_localize)
      const float e = (q - s.p).dot(s.n);
      Eigen::Matrix<float, 6, 1> J;
      J.head<3>() = (q - c).cross(s.n);
      J.tail<3>() = s.n;
      A += J * J.transpose();
      rhs += J * e;
      ++used;
    }
    if (used < 12) return false;
    A.diagonal().array() += 1e-6f;
    const Eigen::Matrix<float, 6, 1> x = A.ldlt().solve(-rhs);
    if (!x.allFinite()) return false;
    const Vec3f w = x.head<3>();
    const float angle = w.norm();
    const Mat3f dR = angle > 1e-9f ? Mat3f(Eigen::AngleAxisf(angle, w / angle)) : Mat3f::Identity();
    T.R = dR * T.R;
    T.t = dR * (T.t - c) + c + x.tail<3>();
    // Re-orthonormalise (float drift over iterations).
    const Eigen::Quaternionf q(T.R);
    T.R = q.normalized().toRotationMatrix();
    radius = std::max(radius * 0.75f, radius_min);
    if (angle < 2e-4f && x.tail<3>().norm() < 2e-5f && radius == radius_min) break;  // 0.01 deg, 20 um
  }
  return true;
}

void Localizer::verify(int m, const Pose& T, const LocalizeParams& params, LocalizedObject& out, int claim_label,
                       float* overlap) const {
  const float cos_inc = cos_deg(params.max_incidence_deg);
  const ModelInfo& info = b_.models[m];
  const OrientedPoint* dense = model_points(m);
  const uint32_t stride = info.dense_count > kIcpPoints ? (info.dense_count + kIcpPoints - 1) / kIcpPoints : 1;
  uint32_t visible = 0, supported = 0, total = 0, violations = 0, claimed = 0;
  double res2 = 0;
  float top = -1e9f, best_grasp = -1e9f;
  const Vec3f centre = T * info.centre_m;
  Vec3f grasp = centre, approach = -ctx_.up;
  for (uint32_t i = 0; i < info.dense_count; i += stride) {
    const Vec3f q = T * dense[i].p;
    const Vec3f n = T.R * dense[i].n;
    ++total;
    const float height = ctx_.has_floor ? ctx_.up.dot(q) + ctx_.floor_offset : ctx_.up.dot(q);
    // Known empty space at the sample and 1.5 voxels inside the model: the first alone also fires
    // at silhouettes, where projective distances along grazing rays overstate free space.
    const float inset = volume_ ? 1.5f * volume_->voxel_m() : 0.0f;
    const bool empty = free_space_at(q) > params.free_space_margin_m &&
                       free_space_at(q - n * inset) > params.free_space_margin_m;
    if (empty || (ctx_.has_floor && height < -2.0f * params.floor_tol_m)) ++violations;
    if (!observable(q, n, cos_inc)) continue;
    if (ctx_.has_floor && height < params.floor_tol_m) continue;  // the floor contact was removed with the bin
    if (volume_) {  // an unobserved model point is occluded, not missing
      const Vec3f g = (q - volume_->origin_m()) / volume_->voxel_m();
      const int x = floor_int(g.x()), y = floor_int(g.y()), z = floor_int(g.z());
      if (x < 0 || y < 0 || z < 0 || x >= volume_->dim() || y >= volume_->dim() || z >= volume_->dim()) continue;
      if (volume_->weight()[volume_->index(x, y, z)] == 0) continue;
    }
    ++visible;
    float d2;
    const int32_t j = nearest(q, params.support_tol_m, d2);
    if (j < 0 || n.dot(b_.scene[j].n) < 0.7f) continue;
    ++supported;
    const float e = (q - b_.scene[j].p).dot(b_.scene[j].n);
    res2 += double(e) * e;
    if (b_.labels[j] != 0 && b_.labels[j] != claim_label) ++claimed;
    top = std::max(top, height);
    // Grasp: a top-facing supported point, high and near the object's centre line.
    const float facing = n.dot(ctx_.up);
    if (facing > 0.8f) {
      const Vec3f off = q - centre;
      const float horiz = (off - ctx_.up * off.dot(ctx_.up)).norm();
      const float g = height - 0.5f * horiz;
      if (g > best_grasp) {
        best_grasp = g;
        grasp = q;
        approach = -n;
      }
    }
  }
  out = LocalizedObject{};
  out.model = m;
  out.T_world_object = T;
  out.score = visible ? float(supported) / float(visible) : 0.0f;
  out.residual_m = supported ? float(std::sqrt(res2 / double(supported))) : 0.0f;
  out.free_space = total ? float(violations) / float(total) : 1.0f;
  out.support = supported;
  out.top_m = supported ? top : 0.0f;
  if (best_grasp == -1e9f && supported) grasp = centre;
  out.grasp_m = grasp;
  out.approach = approach;
  out.size_m = 2.0f * info.half_extent_m;
  if (overlap) *overlap = supported ? float(claimed) / float(supported) : 1.0f;
}

bool Localizer::check_pose(int m, const Pose& T, const LocalizeParams& params, bool refine_first,
                           LocalizedObject& out) const {
  Pose P = T;
  const bool ok = !refine_first || refine(m, P, params);
  verify(m, P, params, out, -1, nullptr);
  return ok;
}

void Localizer::claim(int m, const Pose& T, const LocalizeParams& params, int32_t label) const {
  const ModelInfo& info = b_.models[m];
  const OrientedPoint* dense = model_points(m);
  // Every dense sample (not the ICP subset), with a radius that closes the gaps between samples.
  const float r = std::max(params.support_tol_m, 0.75f * info.dense_step_m);
  for (uint32_t i = 0; i < info.dense_count; ++i) {
    const Vec3f q = T * dense[i].p;
    if ((T.R * dense[i].n).dot(ctx_.viewpoint_m - q) <= 0) continue;
    for_each_within(q, r, label);
  }
}

void Localizer::sort_picking_order(std::size_t count) const {
  // Highest first; an occluded object (low supported share) counts up to 5 cm lower.
  std::sort(b_.results, b_.results + count, [](const LocalizedObject& a, const LocalizedObject& b) {
    if (picking_key(a) != picking_key(b)) return picking_key(a) > picking_key(b);
    if (a.model != b.model) return a.model < b.model;
    if (a.segment != b.segment) return a.segment < b.segment;
    return pose_less(a.T_world_object, b.T_world_object);
  });
}

std::size_t Localizer::refine_all(std::size_t n, const LocalizeParams& params) {
  // Independent, read-only on the scene: any thread count gives the same results; the accepted
  // ones are kept in queue order.
  job_params_ = &params;
  if (parallel_.run) parallel_.run(parallel_.runner, n, &Localizer::refine_job, this);
  else
    for (std::size_t k = 0; k < n; ++k) refine_job(this, k);
  std::size_t kept = 0;
  for (std::size_t k = 0; k < n; ++k)
    if (b_.verified[k].model >= 0) b_.verified[kept++] = b_.verified[k];
  return kept;
}

void Localizer::accept_hypotheses(std::size_t nverified, const LocalizeParams& params, int max_results,
                                  std::size_t& count, int* per_model) const {
  // Best first (explained surface x supported share); a hypothesis whose support is mostly claimed
  // by a better one is a duplicate (or a symmetric twin) or a conflicting explanation. The explained
  // surface is an area (supported samples x the area one verification sample stands for): counted
  // in samples, a small part fitted onto a large one's surface (a bracket on the can) outranked it,
  // as every model is verified with about the same number of samples whatever its size.
  auto sample_area = [this](int m) {
    const ModelInfo& info = b_.models[m];
    const uint32_t stride = info.dense_count > kIcpPoints ? (info.dense_count + kIcpPoints - 1) / kIcpPoints : 1;
    return float(stride) * info.dense_step_m * info.dense_step_m;
  };
  std::sort(b_.verified, b_.verified + nverified, [&sample_area](const LocalizedObject& a, const LocalizedObject& b) {
    const float qa = float(a.support) * sample_area(a.model) * a.score,
                qb = float(b.support) * sample_area(b.model) * b.score;
    if (qa != qb) return qa > qb;
    if (a.model != b.model) return a.model < b.model;
    return pose_less(a.T_world_object, b.T_world_object);
  });
  for (std::size_t k = 0; k < nverified && count < std::size_t(max_results); ++k) {
    LocalizedObject h = b_.verified[k];
    if (h.model < kPerModelCounted && per_model[h.model] >= params.max_per_model) continue;
    LocalizedObject tmp;
    float overlap = 0;
    verify(h.model, h.T_world_object, params, tmp, -1, &overlap);
    if (overlap > params.max_overlap) continue;
    // Only hypotheses about to be accepted try their twins (three ICP runs each).
    if (try_flipped_twins(h.model, params, h)) {
      verify(h.model, h.T_world_object, params, tmp, -1, &overlap);
      if (overlap > params.max_overlap) continue;
    }
    claim(h.model, h.T_world_object, params, int32_t(count) + 1);
    b_.results[count++] = h;
    if (h.model < kPerModelCounted) ++per_model[h.model];
  }
}

void Localizer::recheck_weak_results(const LocalizeParams& params, int max_results, std::size_t& count,
                                     int* per_model) {
  // Results are still in acceptance order here, and each one's surface carries its label, its
  // index + 1 (accept_hypotheses claims with count + 1; sort_picking_order comes later).
  LocalizedObject weak[kRecheckMax];
  int32_t weak_label[kRecheckMax];
  std::size_t nweak = 0, kept = 0;
  for (std::size_t k = 0; k < count; ++k) {
    const LocalizedObject& r = b_.results[k];
    if (r.score < params.recheck_score && nweak < kRecheckMax) {
      weak_label[nweak] = int32_t(k) + 1;
      weak[nweak++] = r;
      if (r.model >= 0 && r.model < kPerModelCounted) --per_model[r.model];
    } else {
      b_.results[kept++] = r;
    }
  }
  if (nweak == 0) return;
  count = kept;
  // Only the weak results' surface is searched: what no result explains was searched by the
  // rounds before (left out: -1); what the others explain stays claimed. (Labels are no longer
  // index + 1 after this; only "claimed or not" is read from here on.)
  for (std::size_t i = 0; i < scene_count_; ++i) {
    int32_t& l = b_.labels[i];
    if (l == 0) l = -1;
    for (std::size_t w = 0; w < nweak; ++w)
      if (l == weak_label[w]) l = 0;
  }
  // Each weak result's surface holds about one part: two peaks per model and weak result are
  // enough (bin_rig_a, one thread: +14 % localisation CPU in one pair, within the VM's noise in
  // three more; a first version with the round's six peaks per model, searching more surface,
  // +44 % in one pair).
  LocalizeParams few = params;
  few.rest_hypotheses = std::min(params.rest_hypotheses, int(2 * nweak));
  std::size_t n = 0;
  if (prepare_rest_scene(params)) {
    for (int m = 0; m < model_count_; ++m) n += queue_rest_hypotheses(m, few, n);
    n = refine_all(n, params);
  }
  // The weak results compete with those hypotheses, after them (at most 2 kRecheckMax per model
  // are queued, half of the slots, so the bound below never drops one).
  for (std::size_t w = 0; w < nweak && n < verified_capacity(); ++w) b_.verified[n++] = weak[w];
  accept_hypotheses(n, params, max_results, count, per_model);
}

bool Localizer::try_flipped_twins(int m, const LocalizeParams& params, LocalizedObject& h) const {
  // A shape that is nearly symmetric under a half turn (a can: top and bottom alike from above)
  // draws its votes to either pose, and which one the voting finds first can change with the last
  // millimetre of the map (bin_rig_a's can, tracked map: found upside down about its own axis
  // after a raycast change of 2e-7 m). The half turns about the bounding box's axes through its
  // centre are refined and verified too, and one that explains the scene better (score x
  // support, as accept_hypotheses orders them) replaces the hypothesis. Each is refined before it
  // is judged: a feature off the axis puts the box centre beside the axis of the body (the can:
  // 8 mm), so the bare half turn lies 16 mm beside the surface it should explain. Costs three
  // more ICP runs per accepted hypothesis. A twin must pass the same thresholds as any hypothesis.
  // The three twins are independent: refined and verified as one parallel batch, then judged in
  // axis order (the same outcome on any thread count).
  TwinBatch batch{this, m, &params, h.T_world_object, {}, {}};
  if (parallel_.run) parallel_.run(parallel_.runner, 3, &Localizer::twin_job, &batch);
  else
    for (std::size_t axis = 0; axis < 3; ++axis) twin_job(&batch, axis);
  const auto quality = [](const LocalizedObject& o) { return float(o.support) * o.score; };
  bool replaced = false;
  for (int axis = 0; axis < 3; ++axis) {
    const LocalizedObject& twin = batch.twin[axis];
    if (batch.refined[axis] && passes_thresholds(twin, params) && quality(twin) > quality(h)) {
      h = twin;
      replaced = true;
    }
  }
  return replaced;
}

void Localizer::twin_job(void* context, std::size_t axis) {
  TwinBatch& b = *static_cast<TwinBatch*>(context);
  const ModelInfo& info = b.me->b_.models[b.m];
  // The half turn about object axis `axis` through centre c: x -> F (x - c) + c.
  Mat3f F = -Mat3f::Identity();
  F(int(axis), int(axis)) = 1.0f;
  Pose flip;
  flip.R = F;
  flip.t = info.centre_m - F * info.centre_m;
  Pose T = b.first * flip;
  b.refined[axis] = b.me->refine(b.m, T, *b.params);
  if (b.refined[axis]) b.me->verify(b.m, T, *b.params, b.twin[axis], -1, nullptr);
}

bool Localizer::passes_thresholds(const LocalizedObject& h, const LocalizeParams& params) {
  return !(h.score < params.min_score || h.support < uint32_t(params.min_support) ||
           h.free_space > params.max_free_space);
}

void Localizer::refine_job(void* self, std::size_t k) {
  const Localizer& me = *static_cast<const Localizer*>(self);
  const LocalizeParams& params = *me.job_params_;
  LocalizedObject& slot = me.b_.verified[k];
  const int m = slot.model;
  Pose T = slot.T_world_object;
  LocalizedObject h;
  if (me.refine(m, T, params)) {
    me.verify(m, T, params, h, -1, nullptr);
    if (!passes_thresholds(h, params)) h.model = -1;
  }
  slot = h;  // model -1: rejected
}

Status Localizer::localize(const LocalizeParams& params, int max_results, std::size_t& count) {
  count = 0;
  if (!b_.scene) return Status::kNotInitialised;
  if (max_results > b_.objects_max) max_results = b_.objects_max;
  // Point pairs vote only within one connected part of the scene (objects that do not touch do
  // not vote for each other's poses): fewer pairs, less clutter.
  connected_components(std::max(2.0f * grid_cell_m_ * 0.5f, params.support_tol_m * 1.5f));
  std::size_t nverified = 0;
  last_candidates_ = 0;
  Cluster clusters[8 * kClustersPerModel];
  for (int m = 0; m < model_count_ && scene_count_ > 0; ++m) {
    const ModelInfo& info = b_.models[m];
    const std::size_t nc = vote_model(m, params, 0);
    last_candidates_ += nc;
    // Greedy clustering, strongest candidates first.
    PoseCandidate* cand = b_.candidates;
    std::sort(cand, cand + nc, votes_then_pose);
    int ncl = 0;
    const float dt = params.cluster_trans_rel * info.diameter_m;
    const float dr = params.cluster_rot_deg * ppf::kPi / 180.0f;
    for (std::size_t k = 0; k < nc; ++k) {
      int found = -1;
      for (int c = 0; c < ncl && found < 0; ++c)
        if (same_pose_cluster(clusters[c].T, cand[k].T_world_object, dt, dr)) found = c;
      if (found >= 0) clusters[found].votes += cand[k].votes;
      else if (ncl < 8 * kClustersPerModel) clusters[ncl++] = Cluster{cand[k].T_world_object, cand[k].votes, uint32_t(k)};
    }
    std::sort(clusters, clusters + ncl, [](const Cluster& a, const Cluster& b) {
      return a.votes > b.votes || (a.votes == b.votes && a.first < b.first);
    });
    // Refine the strongest clusters, at most 3 per neighbourhood (half a diameter): a large curved
    // object attracts many clusters of every model; the others must still get their turn.
    int refined = 0;
    for (int c = 0; c < ncl && refined < kClustersPerModel; ++c) {
      int near = 0;
      for (int p = 0; p < c; ++p)
        near += clusters[p].votes >= 0 && (clusters[p].T.t - clusters[c].T.t).norm() < 0.5f * info.diameter_m;
      if (near < 3 && !plausible(m, clusters[c].T, params)) near = 3;  // cheap pre-check before ICP
      if (near >= 3) {
        clusters[c].votes = -1;  // skipped: does not count as refined
        continue;
      }
      ++refined;
      // Queued: refined and verified below, all models' hypotheses in one parallel batch.
      if (nverified < verified_capacity()) {
        b_.verified[nverified] = LocalizedObject{};
        b_.verified[nverified].model = m;
        b_.verified[nverified++].T_world_object = clusters[c].T;
      }
    }
  }
  nverified = refine_all(nverified, params);
  for (std::size_t i = 0; i < scene_count_; ++i) b_.labels[i] = 0;  // now: claims of accepted poses
  int per_model[kPerModelCounted] = {};
  accept_hypotheses(nverified, params, max_results, count, per_model);
  // Second round: rest-pose hypotheses on the surface no accepted pose explains (labels == 0).
  // Then the recheck round on the weak results' surface.
  if (params.rest_poses && ctx_.has_floor) {
    if (count < std::size_t(max_results) && prepare_rest_scene(params)) {
      std::size_t n2 = 0;
      for (int m = 0; m < model_count_; ++m) n2 += queue_rest_hypotheses(m, params, n2);
      n2 = refine_all(n2, params);
      accept_hypotheses(n2, params, max_results, count, per_model);
    }
    recheck_weak_results(params, max_results, count, per_model);
    for (std::size_t i = 0; i < scene_count_; ++i)  // -1: left out of a round (prepare_rest_scene, recheck)
      if (b_.labels[i] < 0) b_.labels[i] = 0;
  }
  sort_picking_order(count);
  return Status::kOk;
}

}  // namespace edgefuse
