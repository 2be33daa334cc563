// Rest-pose hypotheses: the bin-picking prior that a part lying on the bin floor rests on one of
// its stable faces. Its pose is then fixed up to x, y and yaw, and the height of every model point
// above the floor is known for each resting face. A model point and a scene point at the same
// height vote (per yaw step) for the translation that puts the one onto the other: a 2D Hough
// transform over (x, y), one per resting face and yaw. It uses positions only, no normals, so it
// finds parts whose visible surface is too thin or too blurred for point pair features (an upright
// plate seen edge-on: a 5 mm ridge fused into a blob, plus a flange 5 mm above the floor).
//
// It runs as a second round on the scene surface that no accepted pose explains (labels == 0 after
// the first round's claims), so it costs little when the first round found everything, and its
// hypotheses go through the same ICP + verification (support, free space, overlap) as all others.
// Deterministic: fixed yaw steps, fixed chunking of the (face, yaw) jobs, ties broken by order.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>

#include "edgefuse/localize/localizer.hpp"
#include "edgefuse/math/real.hpp"
#include "pose_order.hpp"
#include "ppf_math.hpp"
#include "sort_keys.hpp"

namespace edgefuse {
namespace {

// Rotation that turns the object-frame direction `down` into -z (the resting face onto the floor).
Mat3f rest_rotation(const Vec3f& down) {
  return Eigen::Quaternionf::FromTwoVectors(down, Vec3f(0, 0, -1)).toRotationMatrix();
}

constexpr int kPeaksPerJob = 2;      // vote peaks kept per (resting face, yaw)
constexpr int kRestClusters = 64;    // pose clusters of one model's rest candidates
constexpr int kNormalClusters = 64;  // start-up: normal directions of flat faces
constexpr int kStabilityDirs = 24;   // start-up: directions of the centroid-inside-contact test

}  // namespace

void Localizer::find_rest_faces(int m) {
  ModelInfo& info = b_.models[m];
  info.rest_count = 0;
  const OrientedPoint* dense = model_points(m);
  const uint32_t n = info.dense_count;
  if (n < 16) return;
  // Flat faces: the dense samples (area-uniform) grouped by normal direction (8 degrees).
  Vec3f seed[kNormalClusters], sum[kNormalClusters];
  uint32_t members[kNormalClusters];
  int nc = 0;
  const float cos_join = std::cos(8.0f * ppf::kPi / 180.0f);
  Vec3f centroid = Vec3f::Zero();
  for (uint32_t i = 0; i < n; ++i) {
    centroid += dense[i].p;
    int c = 0;
    while (c < nc && seed[c].dot(dense[i].n) < cos_join) ++c;
    if (c == nc) {
      if (nc == kNormalClusters) continue;  // a curved model: the largest early groups suffice
      seed[nc] = dense[i].n;
      sum[nc] = Vec3f::Zero();
      members[nc++] = 0;
    }
    sum[c] += dense[i].n;
    ++members[c];
  }
  centroid /= float(n);
  // A face is a resting face when it is the model's extreme plane in its direction (the floor
  // touches it), covers at least 2 % of the surface, and the centroid lies above the contact patch
  // by a margin (checked along kStabilityDirs in-plane directions: the patch's convex hull).
  const float tol = std::max(0.001f, 0.01f * info.diameter_m);
  Vec3f found[kNormalClusters];
  uint32_t area[kNormalClusters];
  int nf = 0;
  for (int c = 0; c < nc; ++c) {
    if (members[c] < std::max<uint32_t>(16, n / 100) || !(sum[c].norm() > 0)) continue;
    const Vec3f d = sum[c].normalized();
    float hmax = -1e30f;
    for (uint32_t i = 0; i < n; ++i) hmax = std::max(hmax, d.dot(dense[i].p));
    uint32_t support = 0;
    for (uint32_t i = 0; i < n; ++i) support += d.dot(dense[i].p) >= hmax - tol;
    if (support < std::max<uint32_t>(16, n / 50)) continue;
    const Vec3f e1 = d.unitOrthogonal(), e2 = d.cross(e1);
    bool stable = true;
    for (int k = 0; k < kStabilityDirs && stable; ++k) {
      const float a = 2.0f * ppf::kPi * float(k) / float(kStabilityDirs);
      const Vec3f u = std::cos(a) * e1 + std::sin(a) * e2;
      float reach = -1e30f;
      for (uint32_t i = 0; i < n; ++i)
        if (d.dot(dense[i].p) >= hmax - tol) reach = std::max(reach, u.dot(dense[i].p));
      stable = reach >= u.dot(centroid) + tol;
    }
    if (!stable) continue;
    bool duplicate = false;
    for (int k = 0; k < nf && !duplicate; ++k) duplicate = found[k].dot(d) > std::cos(10.0f * ppf::kPi / 180.0f);
    if (duplicate) continue;
    found[nf] = d;
    area[nf++] = support;
  }
  // Largest contact patch first (the most likely resting faces), ties in discovery order.
  for (int k = 0; k < kRestFacesMax && k < nf; ++k) {
    int best = -1;
    for (int j = 0; j < nf; ++j)
      if (area[j] > 0 && (best < 0 || area[j] > area[best])) best = j;
    if (best < 0) break;
    info.rest_down[info.rest_count++] = found[best];
    area[best] = 0;
  }
}

float Localizer::rest_coverage(int m, const Pose& T, const LocalizeParams& params) const {
  const ModelInfo& info = b_.models[m];
  const OrientedPoint* dense = model_points(m);
  const uint32_t stride = info.dense_count > 300 ? info.dense_count / 300 : 1;
  const float cos_inc = std::cos(params.max_incidence_deg * (ppf::kPi / 180.0f));
  const float r = std::max(2.0f * params.support_tol_m, rest_.cell_m);
  uint32_t facing = 0, near = 0;
  for (uint32_t i = 0; i < info.dense_count; i += stride) {
    const Vec3f q = T * dense[i].p;
    if (!observable(q, T.R * dense[i].n, cos_inc)) continue;
    if (ctx_.up.dot(q) + ctx_.floor_offset < params.floor_tol_m) continue;  // removed with the floor
    ++facing;
    float d2;
    const int32_t j = nearest(q, r, d2);
    near += j >= 0 && b_.labels[j] == 0;
  }
  // As plausible(): far below the final score threshold, ICP cannot rescue the pose.
  if (near < 4 || float(near) < 0.5f * params.min_score * float(facing)) return 0.0f;
  return float(near) * float(near) / float(facing);
}

bool Localizer::prepare_rest_scene(const LocalizeParams& params) {
  const Vec3f up = ctx_.up.normalized();
  Vec3f a0 = ctx_.floor_axis[0] - up * up.dot(ctx_.floor_axis[0]);
  if (!(a0.norm() > 0.5f)) a0 = up.unitOrthogonal();
  rest_.a0 = a0.normalized();
  rest_.a1 = up.cross(rest_.a0);
  // Unclaimed surface that belongs to a part of the scene mostly explained already (the rims and
  // concave pockets of an accepted pose that its claims missed) is left out: it would only vote
  // for poses the overlap check rejects, and drown the small parts this round is for. Marked -1.
  const float radius = std::max(grid_cell_m_, params.support_tol_m * 1.5f);
  uint32_t* visited = b_.sample;
  std::memset(visited, 0, sizeof(uint32_t) * scene_count_);
  std::size_t tail = 0;
  for (std::size_t seed = 0; seed < scene_count_; ++seed) {
    if (visited[seed] || b_.labels[seed] != 0) continue;
    const std::size_t start = tail;
    tail = grow_component(seed, radius, visited, tail);
    std::size_t claimed = 0;
    for (std::size_t k = start; k < tail; ++k) claimed += b_.labels[b_.queue[k]] != 0;
    if (2 * claimed >= tail - start)
      for (std::size_t k = start; k < tail; ++k)
        if (b_.labels[b_.queue[k]] == 0) b_.labels[b_.queue[k]] = -1;
  }
  // Unclaimed scene points, one per vote cell.
  KeyIndex* keys = reinterpret_cast<KeyIndex*>(b_.scratch);
  const float inv = 1.0f / std::max(params.rest_cell_m, 0.0005f);
  std::size_t nk = 0;
  for (std::size_t i = 0; i < scene_count_; ++i)
    if (b_.labels[i] == 0) keys[nk++] = KeyIndex{cell_key(b_.scene[i].p, inv), i};
  sort_key_index(keys, nk);
  std::size_t ns = 0;
  for (std::size_t i = 0; i < nk; ++i)
    if (i == 0 || keys[i].key != keys[i - 1].key) b_.sample[ns++] = uint32_t(keys[i].index);
  rest_.count = ns;
  if (ns < 8) return false;
  // Packed (x, y, height) in the scratch (the keys are no longer needed), sorted by height bin.
  rest_.bin_m = std::max(params.rest_height_tol_m, 0.0005f);
  auto bin_of = [this, &up](const Vec3f& p) {
    const int b = floor_int((up.dot(p) + ctx_.floor_offset) / rest_.bin_m);
    return b < 0 ? 0 : (b >= kRestHeightBins ? kRestHeightBins - 1 : b);
  };
  std::memset(rest_.bins, 0, sizeof(rest_.bins));
  for (std::size_t k = 0; k < ns; ++k) ++rest_.bins[bin_of(b_.scene[b_.sample[k]].p) + 1];
  for (int b = 0; b < kRestHeightBins; ++b) rest_.bins[b + 1] += rest_.bins[b];
  uint32_t cursor[kRestHeightBins];
  std::memcpy(cursor, rest_.bins, sizeof(cursor));
  float* packed = reinterpret_cast<float*>(b_.scratch);
  rest_.lo[0] = rest_.lo[1] = 1e30f;
  rest_.hi[0] = rest_.hi[1] = -1e30f;
  for (std::size_t k = 0; k < ns; ++k) {
    const Vec3f& p = b_.scene[b_.sample[k]].p;
    float* o = packed + 3 * std::size_t(cursor[bin_of(p)]++);
    o[0] = rest_.a0.dot(p);
    o[1] = rest_.a1.dot(p);
    o[2] = up.dot(p) + ctx_.floor_offset;
    for (int a = 0; a < 2; ++a) {
      rest_.lo[a] = std::min(rest_.lo[a], o[a]);
      rest_.hi[a] = std::max(rest_.hi[a], o[a]);
    }
  }
  return true;
}

// One chunk of rest_vote_job: its (resting face, yaw) jobs of model job_model_ vote into the
// chunk's accumulator; what the jobs share is set up once.
struct Localizer::RestVoter {
  const Localizer& me;
  const LocalizeParams& params;
  const RestScene& rs;
  const int m;
  const ModelInfo& info;
  const OrientedPoint* dense;
  uint16_t* acc;
  const float* packed;
  uint32_t stride;  //!< model samples about as far apart as the scene samples
  float cos_inc, tol, inv_cell;
  Mat3f B;  //!< floor axes and up: the vote frame to the world
  // Cells that received votes are listed (a quarter of the queue per chunk), so finding the peaks
  // and clearing the grid cost as much as the votes, not the grid (most of it stays empty); when
  // the list overflows, the whole grid is scanned (same peaks: ties go to the lower cell index).
  std::size_t cells;
  uint32_t* touched;
  std::size_t touched_cap;
  // The current resting face's frame: its lowest point on the floor.
  int face = -1;
  Mat3f Q = Mat3f::Identity();
  float zmin = 0;
  Vec3f c = Vec3f::Zero();

  RestVoter(const Localizer& localizer, std::size_t chunk);
  //! Job j: (resting face, yaw) j / yaw_steps, j % yaw_steps; its peaks into candidates[2 j, 2 j + 2).
  void run(std::size_t j);
  void enter_face(int f);
  //! The model samples at yaw (cos, sin) vote; returns how many cells received votes.
  std::size_t vote(float cy, float sy) const;
  //! Peak k: the strongest cell at least 3 cells from the earlier peaks (px, py); returns its votes.
  uint16_t strongest_cell(int k, std::size_t nt, bool listed, int* px, int* py) const;
  //! The candidate of the peak at (x0, y0): its votes are its 3 x 3 neighbourhood's, its position
  //! their weighted centre.
  void write_candidate(int x0, int y0, float cy, float sy, PoseCandidate& out) const;
};

Localizer::RestVoter::RestVoter(const Localizer& localizer, std::size_t chunk)
    : me(localizer),
      params(*me.job_params_),
      rs(me.rest_),
      m(me.job_model_),
      info(me.b_.models[m]),
      dense(me.model_points(m)),
      acc(me.b_.votes + chunk * std::size_t(me.b_.ppf_points_max) * kPpfAngleBins),
      packed(reinterpret_cast<const float*>(me.b_.scratch)) {
  const float ratio = info.dense_step_m > 0 ? params.rest_cell_m / info.dense_step_m : 1.0f;
  stride = ratio > 1.0f ? uint32_t(ratio * ratio) : 1u;
  cos_inc = std::cos(params.max_incidence_deg * (ppf::kPi / 180.0f));
  tol = params.rest_height_tol_m;
  inv_cell = 1.0f / rs.cell_m;
  B.col(0) = rs.a0;
  B.col(1) = rs.a1;
  B.col(2) = me.ctx_.up.normalized();
  cells = std::size_t(rs.w) * std::size_t(rs.h);
  touched = me.b_.queue + chunk * (me.b_.scene_points_max / kVoteAccumulators);
  touched_cap = me.b_.scene_points_max / kVoteAccumulators;
  std::memset(acc, 0, sizeof(uint16_t) * cells);
}

void Localizer::RestVoter::enter_face(int f) {
  face = f;
  Q = rest_rotation(info.rest_down[f]);
  zmin = 1e30f;
  for (uint32_t i = 0; i < info.dense_count; ++i) zmin = std::min(zmin, Q.row(2).dot(dense[i].p));
  c = Q * info.centre_m;
}

std::size_t Localizer::RestVoter::vote(float cy, float sy) const {
  std::size_t nt = 0;
  for (uint32_t i = 0; i < info.dense_count; i += stride) {
    // Surface a sensor above the bin can see (facing up within the incidence limit), above the
    // floor band that bin removal took away.
    if ((Q.row(2).dot(dense[i].n)) < cos_inc) continue;
    const Vec3f q = Q * dense[i].p;
    const float height = q.z() - zmin;
    if (height < params.floor_tol_m) continue;
    const float rx = cy * (q.x() - c.x()) - sy * (q.y() - c.y());
    const float ry = sy * (q.x() - c.x()) + cy * (q.y() - c.y());
    const int kb = floor_int(height / rs.bin_m);
    const int b0 = std::max(kb - 1, 0), b1 = std::min(kb + 1, kRestHeightBins - 1);
    if (b0 > b1) continue;
    for (uint32_t s = rs.bins[b0]; s < rs.bins[b1 + 1]; ++s) {
      const float* o = packed + 3 * std::size_t(s);
      if (std::fabs(o[2] - height) > tol) continue;
      const int gx = floor_int((o[0] - rx - rs.origin[0]) * inv_cell);
      const int gy = floor_int((o[1] - ry - rs.origin[1]) * inv_cell);
      if (gx < 0 || gy < 0 || gx >= rs.w || gy >= rs.h) continue;
      const std::size_t cell = std::size_t(gy) * std::size_t(rs.w) + std::size_t(gx);
      uint16_t& v = acc[cell];
      if (v == 0 && nt++ < touched_cap) touched[nt - 1] = uint32_t(cell);
      if (v < 65535) ++v;
    }
  }
  return nt;
}

uint16_t Localizer::RestVoter::strongest_cell(int k, std::size_t nt, bool listed, int* px, int* py) const {
  uint16_t best = 0;
  std::size_t best_cell = cells;
  const std::size_t n_scan = listed ? nt : cells;
  for (std::size_t e = 0; e < n_scan; ++e) {
    const std::size_t cell = listed ? touched[e] : e;
    const uint16_t v = acc[cell];
    if (v < best || v == 0 || (v == best && cell > best_cell)) continue;
    const int x = int(cell % std::size_t(rs.w)), y = int(cell / std::size_t(rs.w));
    bool near = false;
    for (int p = 0; p < k && !near; ++p) near = std::abs(x - px[p]) <= 3 && std::abs(y - py[p]) <= 3;
    if (near) continue;
    best = v;
    best_cell = cell;
    px[k] = x;
    py[k] = y;
  }
  return best;
}

void Localizer::RestVoter::write_candidate(int x0, int y0, float cy, float sy, PoseCandidate& out) const {
  float sw = 0, sx = 0, sy2 = 0;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) {
      const int x = x0 + dx, y = y0 + dy;
      if (x < 0 || y < 0 || x >= rs.w || y >= rs.h) continue;
      const float v = float(acc[std::size_t(y) * std::size_t(rs.w) + std::size_t(x)]);
      sw += v;
      sx += v * float(x);
      sy2 += v * float(y);
    }
  const float ux = rs.origin[0] + (sx / sw + 0.5f) * rs.cell_m, uy = rs.origin[1] + (sy2 / sw + 0.5f) * rs.cell_m;
  Mat3f Rz;
  Rz << cy, -sy, 0, sy, cy, 0, 0, 0, 1;
  // World = B * (Rz * (Q p) + t_c): the model centre's column lands on (ux, uy), the resting
  // face on the floor (height = up . x + floor_offset).
  const Vec3f rc = Rz * c;
  const Vec3f t_c(ux - rc.x(), uy - rc.y(), -zmin - me.ctx_.floor_offset);
  out.T_world_object.R = B * Rz * Q;
  out.T_world_object.t = B * t_c;
  out.votes = sw;
  out.model = m;
}

void Localizer::RestVoter::run(std::size_t j) {
  const int f = int(j / std::size_t(rs.yaw_steps));
  const float yaw = 2.0f * ppf::kPi * float(j % std::size_t(rs.yaw_steps)) / float(rs.yaw_steps);
  if (f != face) enter_face(f);
  const float cy = std::cos(yaw), sy = std::sin(yaw);
  const std::size_t nt = vote(cy, sy);
  const bool listed = nt <= touched_cap;
  int px[kPeaksPerJob] = {-1, -1}, py[kPeaksPerJob] = {-1, -1};
  for (int k = 0; k < kPeaksPerJob; ++k) {
    const uint16_t best = strongest_cell(k, nt, listed, px, py);
    PoseCandidate& out = me.b_.candidates[kPeaksPerJob * j + std::size_t(k)];
    out.votes = 0;
    if (best >= 3) write_candidate(px[k], py[k], cy, sy, out);
  }
  if (listed)
    for (std::size_t e = 0; e < nt; ++e) acc[touched[e]] = 0;
  else
    std::memset(acc, 0, sizeof(uint16_t) * cells);
}

void Localizer::rest_vote_job(void* self, std::size_t chunk) {
  RestVoter voter(*static_cast<const Localizer*>(self), chunk);
  const std::size_t jobs = std::size_t(voter.rs.faces) * std::size_t(voter.rs.yaw_steps);
  const std::size_t lo = chunk * jobs / kVoteAccumulators, hi = (chunk + 1) * jobs / kVoteAccumulators;
  for (std::size_t j = lo; j < hi; ++j) voter.run(j);
}

std::size_t Localizer::queue_rest_hypotheses(int m, const LocalizeParams& params, std::size_t first) {
  const ModelInfo& info = b_.models[m];
  const std::size_t cap_verified = verified_capacity();
  if (info.rest_count == 0 || rest_.count == 0 || first >= cap_verified || params.rest_hypotheses <= 0) return 0;
  // Vote grid over the samples' extent plus half the model (the model centre's column can lie
  // beside the visible fragments); coarser cells when it would not fit one accumulator.
  const float margin = 0.5f * info.diameter_m;
  const float ext_x = rest_.hi[0] - rest_.lo[0] + 2.0f * margin, ext_y = rest_.hi[1] - rest_.lo[1] + 2.0f * margin;
  const std::size_t cap = std::size_t(b_.ppf_points_max) * kPpfAngleBins;
  float cell = std::max(params.rest_cell_m, std::sqrt(ext_x * ext_y / float(cap)));
  for (;;) {
    rest_.w = int(ext_x / cell) + 2;
    rest_.h = int(ext_y / cell) + 2;
    if (std::size_t(rest_.w) * std::size_t(rest_.h) <= cap) break;
    cell *= 1.05f;
  }
  rest_.cell_m = cell;
  rest_.origin[0] = rest_.lo[0] - margin;
  rest_.origin[1] = rest_.lo[1] - margin;
  rest_.faces = info.rest_count;
  rest_.yaw_steps = std::max(params.rest_yaw_steps, 4);
  const std::size_t per_yaw = std::size_t(rest_.faces) * kPeaksPerJob;
  if (per_yaw * std::size_t(rest_.yaw_steps) > b_.hypotheses_max) rest_.yaw_steps = int(b_.hypotheses_max / per_yaw);
  if (rest_.yaw_steps < 4) return 0;
  job_params_ = &params;
  job_model_ = m;
  if (parallel_.run) parallel_.run(parallel_.runner, kVoteAccumulators, &Localizer::rest_vote_job, this);
  else
    for (std::size_t c = 0; c < std::size_t(kVoteAccumulators); ++c) rest_vote_job(this, c);
  // Compact in job order, strongest first, then greedy pose clustering (as the PPF candidates).
  const std::size_t slots = std::size_t(rest_.faces) * std::size_t(rest_.yaw_steps) * kPeaksPerJob;
  PoseCandidate* cand = b_.candidates;
  std::size_t nc = 0;
  for (std::size_t k = 0; k < slots; ++k)
    if (cand[k].votes > 0) cand[nc++] = cand[k];
  std::sort(cand, cand + nc, votes_then_pose);
  Pose cl_T[kRestClusters];
  int ncl = 0;
  const float dt = params.cluster_trans_rel * info.diameter_m;
  const float dr = params.cluster_rot_deg * ppf::kPi / 180.0f;
  for (std::size_t k = 0; k < nc; ++k) {
    int found = -1;
    for (int c = 0; c < ncl && found < 0; ++c)
      if (same_pose_cluster(cl_T[c], cand[k].T_world_object, dt, dr)) found = c;
    if (found < 0 && ncl < kRestClusters) {
      cl_T[ncl++] = cand[k].T_world_object;  // its strongest peak: later, weaker ones add nothing
    }
  }
  // The strongest clusters are ranked by what they explain: visible model samples (facing the
  // sensor, above the floor band) with an unclaimed scene point near them, as count x share. Vote
  // counts alone favour large flat faces matching any flat fragment at their height.
  float rank[kRestClusters];
  const int ranked = std::min(ncl, kRestClusters / 2);
  for (int c = 0; c < ranked; ++c) rank[c] = rest_coverage(m, cl_T[c], params);
  std::size_t queued = 0;
  bool used[kRestClusters] = {};
  while (queued < std::size_t(params.rest_hypotheses) && first + queued < cap_verified) {
    int best = -1;
    for (int c = 0; c < ranked; ++c)
      if (!used[c] && rank[c] > 0 && (best < 0 || rank[c] > rank[best])) best = c;
    if (best < 0) break;
    used[best] = true;
    LocalizedObject& slot = b_.verified[first + queued++];
    slot = LocalizedObject{};
    slot.model = m;
    slot.T_world_object = cl_T[best];
  }
  return queued;
}

}  // namespace edgefuse
