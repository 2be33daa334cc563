// A picture of a fused cloud and the objects localised in it: an orthographic point-splat and
// triangle rasteriser with a depth buffer (host code, may allocate). `edgefuse render` writes it
// as a PNG; docs/edgefuse_bin_rig_a.png is made with it.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "edgefuse/core/image.hpp"
#include "edgefuse/io/cloud.hpp"
#include "edgefuse/math/pose.hpp"

namespace edgefuse::cli {

//! One localised object: its model mesh (model frame) at T_world_object.
struct RenderObject {
  const io::TriangleMesh* mesh = nullptr;
  Pose T_world_object;
};

struct RenderOptions {
  int width_px = 800;   //!< image width; the height follows the scene's extent (at most 2x the width)
  int point_px = 0;     //!< edge of the square drawn for each cloud point (0: from the image area per point)
  float tilt_deg = 30;  //!< the view turned by this about the image's x axis away from the cloud's mean normal
  float margin = 0.04f; //!< blank border, as a share of the width
};

struct RenderImage {
  int width = 0, height = 0;
  std::vector<Rgb8> px;  //!< row-major
};

//! The colour object i (0-based, picking order) is drawn in.
Rgb8 object_colour(int i);
//! The background colour.
constexpr Rgb8 kRenderBackground{255, 255, 255};

//! Draws `cloud` (its colours where it has them, else shaded grey) seen along the negative mean of
//! its normals (along +z without normals), tilted by `tilt_deg`, and every object's mesh in
//! object_colour(i) with flat shading, in front of the cloud where they coincide.
//! \return false with `err` set when the cloud is empty or an object has no mesh
bool render_scene(const io::PointCloud& cloud, const std::vector<RenderObject>& objects, const RenderOptions& o,
                  RenderImage& out, std::string& err);

}  // namespace edgefuse::cli
