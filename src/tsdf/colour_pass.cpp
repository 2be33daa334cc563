#include "edgefuse/tsdf/colour_pass.hpp"

#include "edgefuse/tsdf/integrate.hpp"

namespace edgefuse {

template <class Real>
Status paint_colour(TsdfVolume& volume, const PinholeIntrinsics& intr, ImageView<const Real> ray_norms,
                    ImageView<const Rgb8> colour, const Pose& T_world_cam, const RaycastMaps& maps,
                    FrameScratch& scratch, ImageView<uint16_t> depth_scratch) {
  if (!volume.has_colour() || colour.empty()) return Status::kInvalidArgument;
  if (depth_scratch.empty() || depth_scratch.width != intr.width || depth_scratch.height != intr.height)
    return Status::kInvalidArgument;
  Status s = raycast<Real>(volume, intr, T_world_cam, maps);
  if (s != Status::kOk) return s;
  // The model's z-depth as the frame's raw depth (rounded to the sensor's depth steps).
  for (int v = 0; v < intr.height; ++v)
    for (int u = 0; u < intr.width; ++u) {
      const float z = maps.depth_m.at(u, v);
      const float raw = z * intr.depth_scale + 0.5f;
      depth_scratch.at(u, v) = z > 0.0f && raw < 65535.0f ? uint16_t(raw) : uint16_t(0);
    }
  DepthFrame frame;
  frame.depth = depth_scratch;
  frame.colour = colour;
  IntegrationJob<Real> job;
  s = prepare_integration<Real>(volume, intr, ray_norms, frame, T_world_cam, 1.0f, scratch, job);
  if (s != Status::kOk) return s;
  job.colour_only = true;
  const std::size_t count = select_bricks(volume, intr, T_world_cam);
  integrate_bricks<Real>(volume, job, 0, count);
  return Status::kOk;
}

template Status paint_colour<float>(TsdfVolume&, const PinholeIntrinsics&, ImageView<const float>,
                                    ImageView<const Rgb8>, const Pose&, const RaycastMaps&, FrameScratch&,
                                    ImageView<uint16_t>);
template Status paint_colour<Fixed>(TsdfVolume&, const PinholeIntrinsics&, ImageView<const Fixed>,
                                    ImageView<const Rgb8>, const Pose&, const RaycastMaps&, FrameScratch&,
                                    ImageView<uint16_t>);

}  // namespace edgefuse
