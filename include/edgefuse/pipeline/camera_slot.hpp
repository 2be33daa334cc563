// One pinhole camera bound to its slot of the board's per-sensor buffers (memory map regions of
// sensor `slot`): the pre-filtered depth image, trust map, ray norms, tile scratch, raycast maps,
// frame pyramid and ICP row sums, with the camera's pre-filters and noise model. Every program
// that maps a camera (edgefused, `edgefuse track|fuse|localize|calibrate`) binds one per camera
// at start-up; nothing here allocates.
#pragma once

#include <cstdint>

#include "edgefuse/filters/depth_filter_chain.hpp"
#include "edgefuse/fusion/fusion_rules.hpp"
#include "edgefuse/memory/memmap.hpp"
#include "edgefuse/sensor/noise_model.hpp"
#include "edgefuse/tracking/icp.hpp"
#include "edgefuse/tracking/pyramid.hpp"

namespace edgefuse {

//! One camera frame as the pipeline takes it: views of the device's (or file's) images.
struct SensorFrame {
  ImageView<const uint16_t> depth;      //!< raw z-depth (intrinsics.depth_scale units), 0 = none
  ImageView<const uint16_t> amplitude;  //!< ToF amplitude of the same size, or empty
  ImageView<const Rgb8> colour;         //!< pixel-registered colour, or empty
  uint64_t stamp_us = 0;                //!< capture stamp (the frame clock)
};

struct CameraSlot {
  int slot = -1;                  //!< sensor slot of the board's per-sensor buffers
  PinholeIntrinsics intr;
  DepthSensorKind kind = DepthSensorKind::kStructuredLight;
  ImageView<real_t> ray_norms;    //!< |ray| per pixel
  FrameScratch scratch;           //!< integration tiles
  RaycastMaps maps;               //!< the model raycast at the tracking pose (colour only when bound with it)
  ImageView<uint16_t> filtered;   //!< the pre-filtered depth of the last frame
  ImageView<uint8_t> trust;       //!< trust map (empty when the board has none)
  FramePyramid<real_t> pyramid;   //!< tracking pyramid of the last frame
  IcpWorkspace<real_t> icp_ws;    //!< ICP row sums
  DepthFilterChain<real_t> filters;
  NoiseModel noise;
  NoiseMean sigma;                //!< median modelled noise of the frames fused with a trust map
  //! What mapping counted for this camera's frames (reports).
  struct MapCounts {
    uint64_t pixels = 0;        //!< pixels with depth after the filters (with a noise gate)
    uint64_t gated_pixels = 0;  //!< of those, dropped by the noise gate
    double jump_m_sum = 0.0;    //!< sum of the frames' depth-jump limits
    uint32_t jump_frames = 0;   //!< frames a limit was set for
  } counts;

  //! Binds slot `slot` of `buffers` to a camera (start-up).
  //! \param buffers the carved memory map  \param board its capacities  \param slot_index sensor slot
  //! \param intrinsics the camera  \param sensor_kind structured light or ToF (filters, noise model)
  //! \param bilateral run the bilateral filter  \param colour_map also raycast colour
  //! \param why the refusal, when not kOk (static text)
  //! \return kCapacityExceeded (slot, image or pyramid beyond the board), kInvalidArgument (intrinsics, filters)
  Status bind(const CoreBuffers& buffers, const BoardCapacities& board, int slot_index,
              const PinholeIntrinsics& intrinsics, DepthSensorKind sensor_kind, bool bilateral, bool colour_map,
              const char** why);

  //! Runs the pre-filters on `frame` into `filtered` (which may be frame.depth's own memory).
  //! \param frame the raw frame  \param scratch a spare image at least as large, overlapping neither
  Status filter(const SensorFrame& frame, ImageView<uint16_t> scratch) const;

  //! Mean median noise of the frames fused with a trust map (0 before any).
  float median_sigma() const { return sigma.mean_m(); }
  bool tof() const { return kind == DepthSensorKind::kTimeOfFlight; }
};

}  // namespace edgefuse
