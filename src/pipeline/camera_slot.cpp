#include "edgefuse/pipeline/camera_slot.hpp"

namespace edgefuse {

Status CameraSlot::bind(const CoreBuffers& b, const BoardCapacities& board, int slot_index,
                        const PinholeIntrinsics& intrinsics, DepthSensorKind sensor_kind, bool bilateral,
                        bool colour_map, const char** why) {
  if (slot_index < 0 || slot_index >= board.sensors_max) {
    *why = "the board has no buffers for this sensor slot";
    return Status::kCapacityExceeded;
  }
  if (intrinsics.width > board.image_width_max || intrinsics.height > board.image_height_max) {
    *why = "the image exceeds the board's largest image";
    return Status::kCapacityExceeded;
  }
  slot = slot_index;
  intr = intrinsics;
  kind = sensor_kind;
  const std::size_t off = std::size_t(slot) * b.pixels_per_sensor;
  const int w = intr.width, h = intr.height;
  static_assert(sizeof(real_t) == sizeof(float), "the ray-norm region holds 4-byte scalars");
  ray_norms = ImageView<real_t>(reinterpret_cast<real_t*>(b.ray_norms) + off, w, h);
  if (build_ray_norms<real_t>(intr, ray_norms) != Status::kOk) {
    *why = "bad intrinsics";
    return Status::kInvalidArgument;
  }
  scratch = b.scratch(slot);
  maps = b.raycast_maps(slot, w, h, colour_map);
  filtered = ImageView<uint16_t>(b.depth_frames + off, w, h);
  trust = b.trust_maps != nullptr ? ImageView<uint8_t>(b.trust_maps + off, w, h) : ImageView<uint8_t>();
  if (b.pyramid<real_t>(slot, intr, pyramid) != Status::kOk) {
    *why = "the frame pyramid does not fit the board's buffers";
    return Status::kCapacityExceeded;
  }
  icp_ws = b.icp_workspace<real_t>(slot);
  filters = DepthFilterChain<real_t>::defaults_for(intr, kind);
  filters.bilateral_enabled = bilateral;
  if (filters.prepare(intr) != Status::kOk) {
    *why = "the depth filters refuse its intrinsics";
    return Status::kInvalidArgument;
  }
  noise = tof() ? NoiseModel::time_of_flight() : NoiseModel::structured_light();
  sigma = NoiseMean();
  counts = MapCounts();
  return Status::kOk;
}

Status CameraSlot::filter(const SensorFrame& frame, ImageView<uint16_t> spare) const {
  const int w = frame.depth.width, h = frame.depth.height;
  return filters.run(frame.depth, frame.amplitude, ImageView<uint16_t>(spare.data, w, h),
                     ImageView<uint16_t>(filtered.data, w, h));
}

}  // namespace edgefuse
