// Point pair feature voting (Drost et al. 2010): every ref_stride-th subsampled scene point is a
// reference; its pairs with the subsampled scene points within the model diameter look up the
// model table and vote for (model reference point, alpha); the peak gives one pose candidate.
// References are independent: they are voted in kVoteAccumulators fixed chunks (one accumulator
// each) over the caller's threads, each writing its own candidate slot, so the candidate list is
// the same for any thread count.
#include <cmath>
#include <cstring>

#include "edgefuse/localize/localizer.hpp"
#include "ppf_math.hpp"

namespace edgefuse {
namespace {

//! bin modulo kPpfAngleBins (non-negative). The voted angle is a difference of two angles in
//! [-pi, pi], so its bin lies within one turn of the range and one add or subtract wraps it,
//! without the two integer remainders per vote; anything else takes the remainder.
//! \param bin the unwrapped angle bin  \return the bin in [0, kPpfAngleBins)
inline int wrap_angle_bin(int bin) {
  if (bin < 0) bin += kPpfAngleBins;
  else if (bin >= kPpfAngleBins) bin -= kPpfAngleBins;
  if (bin < 0 || bin >= kPpfAngleBins) bin = ((bin % kPpfAngleBins) + kPpfAngleBins) % kPpfAngleBins;
  return bin;
}

}  // namespace

bool Localizer::vote_reference(int m, std::size_t r, std::size_t ns, uint16_t* votes, PoseCandidate& c) const {
  const ModelInfo& info = b_.models[m];
  const OrientedPoint* sparse = b_.ppf_points + std::size_t(m) * b_.ppf_points_max;
  const uint32_t* buckets = b_.ppf_buckets + std::size_t(m) * (kPpfBuckets + 1);
  const PpfEntry* entries = b_.ppf_entries + std::size_t(m) * b_.ppf_points_max * (b_.ppf_points_max - 1);
  const float inv_step = 1.0f / info.ppf_step_m;
  const float max_d = info.diameter_m;
  const std::size_t acc_size = std::size_t(info.ppf_count) * kPpfAngleBins;
  const float bin_scale = float(kPpfAngleBins) / (2.0f * ppf::kPi);
  const ScenePoint& sr = b_.scene[b_.sample[r]];
  const Mat3f R_sg = ppf::align_to_x(sr.n);
  std::memset(votes, 0, acc_size * sizeof(uint16_t));
  const int32_t component = b_.labels[b_.sample[r]];
  for (std::size_t i = 0; i < ns; ++i) {
    if (i == r || b_.labels[b_.sample[i]] != component) continue;  // pairs within one connected part
    const ScenePoint& si = b_.scene[b_.sample[i]];
    uint32_t key;
    if (!ppf::feature_key(sr.p, sr.n, si.p, si.n, inv_step, max_d, key)) continue;
    const uint32_t bk = ppf::bucket_of(key);
    const uint32_t e0 = buckets[bk], e1 = buckets[bk + 1];
    if (e0 == e1) continue;
    const float alpha_s = ppf::alpha_of(R_sg, sr.p, si.p);
    for (uint32_t e = e0; e < e1; ++e) {
      if (entries[e].key != key) continue;
      float a = ppf::alpha_from_q(entries[e].alpha_q) - alpha_s;
      const int bin = wrap_angle_bin(floor_int((a + ppf::kPi) * bin_scale));
      uint16_t& v = votes[std::size_t(entries[e].ref) * kPpfAngleBins + std::size_t(bin)];
      if (v < 65535) ++v;
    }
  }
  std::size_t best = 0;
  uint16_t best_v = 0;
  for (std::size_t k = 0; k < acc_size; ++k)
    if (votes[k] > best_v) {
      best_v = votes[k];
      best = k;
    }
  if (best_v < 3) return false;
  const OrientedPoint& mr = sparse[best / kPpfAngleBins];
  const float alpha = (float(best % kPpfAngleBins) + 0.5f) / bin_scale - ppf::kPi;
  c.T_world_object.R = R_sg.transpose() * ppf::rot_x(alpha) * ppf::align_to_x(mr.n);
  c.T_world_object.t = sr.p - c.T_world_object.R * mr.p;
  c.votes = float(best_v);
  c.model = m;
  return true;
}

void Localizer::vote_job(void* self, std::size_t chunk) {
  const Localizer& me = *static_cast<const Localizer*>(self);
  const std::size_t stride = me.job_stride_;
  const std::size_t lo = chunk * me.job_refs_ / kVoteAccumulators, hi = (chunk + 1) * me.job_refs_ / kVoteAccumulators;
  uint16_t* votes = me.b_.votes + chunk * std::size_t(me.b_.ppf_points_max) * kPpfAngleBins;
  for (std::size_t j = lo; j < hi; ++j) {
    PoseCandidate& c = me.b_.candidates[me.job_first_ + j];
    if (!me.vote_reference(me.job_model_, j * stride, me.job_ns_, votes, c)) c.votes = 0;  // no peak
  }
}

std::size_t Localizer::vote_model(int m, const LocalizeParams& params, std::size_t first) {
  const std::size_t ns = subsample_scene(b_.models[m].ppf_step_m);
  std::size_t stride = params.ref_stride > 0 ? std::size_t(params.ref_stride) : 1;
  // A large model's coarse step leaves few scene samples (bin_rig_a's can: ~130 at 25 mm): every
  // one of them is then a reference, which costs little and keeps its pose from hanging on a
  // handful of votes (in a sparser, tracked map the can got no usable candidate with every 2nd).
  if (stride > 1 && ns / stride < std::size_t(params.min_references)) stride = 1;
  job_stride_ = stride;
  std::size_t refs = (ns + stride - 1) / stride;
  if (first >= b_.hypotheses_max) return 0;
  if (refs > b_.hypotheses_max - first) refs = b_.hypotheses_max - first;  // one slot per reference
  job_params_ = &params;
  job_model_ = m;
  job_ns_ = ns;
  job_refs_ = refs;
  job_first_ = first;
  if (parallel_.run) parallel_.run(parallel_.runner, kVoteAccumulators, &Localizer::vote_job, this);
  else
    for (std::size_t c = 0; c < std::size_t(kVoteAccumulators); ++c) vote_job(this, c);
  // Compact the references' slots in reference order (the order the serial loop produced).
  std::size_t out = first;
  for (std::size_t j = 0; j < refs; ++j)
    if (b_.candidates[first + j].votes > 0) b_.candidates[out++] = b_.candidates[first + j];
  return out - first;
}

}  // namespace edgefuse
