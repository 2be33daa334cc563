#include "edgefuse/pipeline/kernels.hpp"

#include "edgefuse/math/real.hpp"

namespace edgefuse {
namespace {

template <class Real>
struct IntegrateRows {
  TsdfVolume* volume;
  const IntegrationJob<Real>* job;
  std::size_t bricks;
};

template <class Real>
void integrate_rows(void* p, int begin, int end) {
  auto* c = static_cast<IntegrateRows<Real>*>(p);
  const std::size_t b = std::size_t(begin) * kIntegrateBricksPerRow;
  std::size_t e = std::size_t(end) * kIntegrateBricksPerRow;
  if (e > c->bricks) e = c->bricks;
  if (b < e) integrate_bricks(*c->volume, *c->job, b, e);
}

template <class Real>
struct RaycastRows {
  const TsdfVolume* volume;
  const PinholeIntrinsics* intr;
  const Pose* pose;
  const RaycastMaps* maps;
};

template <class Real>
void raycast_band(void* p, int begin, int end) {
  auto* c = static_cast<RaycastRows<Real>*>(p);
  const int b = begin * kRaycastRowsPerRow;
  const int e = end * kRaycastRowsPerRow < c->intr->height ? end * kRaycastRowsPerRow : c->intr->height;
  if (b < e) raycast_rows<Real>(*c->volume, *c->intr, *c->pose, *c->maps, b, e);
}

}  // namespace

template <class Real>
Status integrate_frame(const RowRunner* runner, TsdfVolume& volume, const PinholeIntrinsics& intr,
                       ImageView<const Real> ray_norms, const DepthFrame& frame, const Pose& T_world_cam,
                       FrameScratch& scratch, float trust) {
  IntegrationJob<Real> job;
  const Status s = prepare_integration(volume, intr, ray_norms, frame, T_world_cam, trust, scratch, job);
  if (s != Status::kOk) return s;
  IntegrateRows<Real> c{&volume, &job, select_band_bricks(volume, intr, frame, T_world_cam)};
  const int rows = int((c.bricks + kIntegrateBricksPerRow - 1) / kIntegrateBricksPerRow);
  if (runner != nullptr && runner->run != nullptr)
    runner->run(runner->self, &integrate_rows<Real>, &c, rows);
  else
    integrate_rows<Real>(&c, 0, rows);
  finish_integration(volume, c.bricks);
  return Status::kOk;
}

template <class Real>
Status raycast_frame(const RowRunner* runner, const TsdfVolume& volume, const PinholeIntrinsics& intr,
                     const Pose& T_world_cam, const RaycastMaps& maps) {
  const Status s = prepare_raycast(volume, intr, T_world_cam, maps);
  if (s != Status::kOk) return s;
  RaycastRows<Real> c{&volume, &intr, &T_world_cam, &maps};
  const int rows = (intr.height + kRaycastRowsPerRow - 1) / kRaycastRowsPerRow;
  if (runner != nullptr && runner->run != nullptr)
    runner->run(runner->self, &raycast_band<Real>, &c, rows);
  else
    raycast_band<Real>(&c, 0, rows);
  return Status::kOk;
}

#define EDGEFUSE_INSTANTIATE(Real)                                                                              \
  template Status integrate_frame<Real>(const RowRunner*, TsdfVolume&, const PinholeIntrinsics&,               \
                                        ImageView<const Real>, const DepthFrame&, const Pose&, FrameScratch&,  \
                                        float);                                                                \
  template Status raycast_frame<Real>(const RowRunner*, const TsdfVolume&, const PinholeIntrinsics&,           \
                                      const Pose&, const RaycastMaps&);
EDGEFUSE_INSTANTIATE(float)
EDGEFUSE_INSTANTIATE(Fixed)
#undef EDGEFUSE_INSTANTIATE

}  // namespace edgefuse
