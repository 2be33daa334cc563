// Colour transfer (paper section 3.3: "colour from the RGB-D sensor colours the fused cloud").
//
// The RGB-D camera's colour is fused where its own depth sees a surface (integrate()). Geometry
// that only another sensor measured -- the RGB-D depth missing there (projector shadow, a dark or
// shiny part, out of range) while its colour image still sees it -- would stay uncoloured. The
// paint pass fixes that after the geometry is fused: the space is raycast at the colour camera's
// pose, the model's depth stands in for the measured depth, and the integration kernel in
// colour-only mode blends the image's colour into the observed voxels within the colour band of
// that model surface (so occluded voxels are never painted). Distances and weights are untouched.
// Voxels no colour image saw keep colour weight 0: the extracted points stay uncoloured (alpha 0),
// never painted white.
#pragma once

#include "edgefuse/core/image.hpp"
#include "edgefuse/core/status.hpp"
#include "edgefuse/math/pose.hpp"
#include "edgefuse/sensor/pinhole.hpp"
#include "edgefuse/tsdf/frame_scratch.hpp"
#include "edgefuse/tsdf/raycast.hpp"
#include "edgefuse/tsdf/volume.hpp"

namespace edgefuse {

//! Paints one colour image onto the fused surface.
//! \param volume the space (with colour storage)
//! \param intr the colour camera's intrinsics (colour registered to this pinhole)
//! \param ray_norms |ray| per pixel of that camera
//! \param colour the image
//! \param T_world_cam the camera's pose
//! \param maps raycast outputs of that camera's size (depth required; overwritten)
//! \param scratch the camera's tile scratch
//! \param depth_scratch raw depth image of the camera's size (overwritten with the model depth)
template <class Real>
Status paint_colour(TsdfVolume& volume, const PinholeIntrinsics& intr, ImageView<const Real> ray_norms,
                    ImageView<const Rgb8> colour, const Pose& T_world_cam, const RaycastMaps& maps,
                    FrameScratch& scratch, ImageView<uint16_t> depth_scratch);

}  // namespace edgefuse
