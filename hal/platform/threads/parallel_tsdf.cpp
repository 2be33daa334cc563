#include "edgefuse/hal/platform/threads/parallel_tsdf.hpp"

#include <atomic>
#include <cstddef>

namespace edgefuse {
namespace {

constexpr std::size_t kBricksPerChunk = 32;
constexpr int kRowsPerChunk = FrameScratch::kTile;  // one band of tiles

template <class Real>
struct IntegrateContext {
  TsdfVolume* volume;
  const IntegrationJob<Real>* job;
  std::size_t count;
  std::atomic<std::size_t> next{0};
};

template <class Real>
void integrate_worker(void* p, int, int) {
  auto* c = static_cast<IntegrateContext<Real>*>(p);
  for (;;) {
    const std::size_t begin = c->next.fetch_add(kBricksPerChunk);
    if (begin >= c->count) return;
    const std::size_t end = begin + kBricksPerChunk < c->count ? begin + kBricksPerChunk : c->count;
    integrate_bricks(*c->volume, *c->job, begin, end);
  }
}

template <class Real>
struct RaycastContext {
  const TsdfVolume* volume;
  const PinholeIntrinsics* intr;
  const Pose* pose;
  const RaycastMaps* maps;
  std::atomic<int> next{0};
};

template <class Real>
void raycast_worker(void* p, int, int) {
  auto* c = static_cast<RaycastContext<Real>*>(p);
  for (;;) {
    const int begin = c->next.fetch_add(kRowsPerChunk);
    if (begin >= c->intr->height) return;
    const int end = begin + kRowsPerChunk < c->intr->height ? begin + kRowsPerChunk : c->intr->height;
    raycast_rows<Real>(*c->volume, *c->intr, *c->pose, *c->maps, begin, end);
  }
}

}  // namespace

template <class Real>
Status integrate_parallel(WorkerPool& pool, TsdfVolume& volume, const PinholeIntrinsics& intr,
                          ImageView<const Real> ray_norms, const DepthFrame& frame, const Pose& T_world_cam,
                          FrameScratch& scratch, float trust) {
  IntegrationJob<Real> job;
  const Status s = prepare_integration(volume, intr, ray_norms, frame, T_world_cam, trust, scratch, job);
  if (s != Status::kOk) return s;
  IntegrateContext<Real> c;
  c.volume = &volume;
  c.job = &job;
  c.count = select_bricks(volume, intr, T_world_cam);
  pool.run(&integrate_worker<Real>, &c);
  finish_integration(volume, c.count);
  return Status::kOk;
}

template <class Real>
Status raycast_parallel(WorkerPool& pool, const TsdfVolume& volume, const PinholeIntrinsics& intr,
                        const Pose& T_world_cam, const RaycastMaps& maps) {
  const Status s = prepare_raycast(volume, intr, T_world_cam, maps);
  if (s != Status::kOk) return s;
  RaycastContext<Real> c;
  c.volume = &volume;
  c.intr = &intr;
  c.pose = &T_world_cam;
  c.maps = &maps;
  pool.run(&raycast_worker<Real>, &c);
  return Status::kOk;
}

template Status integrate_parallel<float>(WorkerPool&, TsdfVolume&, const PinholeIntrinsics&, ImageView<const float>,
                                          const DepthFrame&, const Pose&, FrameScratch&, float);
template Status integrate_parallel<Fixed>(WorkerPool&, TsdfVolume&, const PinholeIntrinsics&, ImageView<const Fixed>,
                                          const DepthFrame&, const Pose&, FrameScratch&, float);
template Status raycast_parallel<float>(WorkerPool&, const TsdfVolume&, const PinholeIntrinsics&, const Pose&,
                                        const RaycastMaps&);
template Status raycast_parallel<Fixed>(WorkerPool&, const TsdfVolume&, const PinholeIntrinsics&, const Pose&,
                                        const RaycastMaps&);

}  // namespace edgefuse
