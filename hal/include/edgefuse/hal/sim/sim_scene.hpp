// The simulated rig's scene: analytic solids (oriented boxes and capped cylinders) that the sim
// backends ray-cast exactly. default_bin_scene() rebuilds bin_rig_a (../shared/data/bin_rig_a,
// README "Scene"): the open bin and its six objects at their true poses, with boxes and cylinders
// standing in for the meshes (the bracket is two boxes, the watering can a cylinder of its size).
// Fixed capacity, no heap: the scene lives in the sim device objects.
#pragma once

#include <cstdint>

#include "edgefuse/core/image.hpp"
#include "edgefuse/math/pose.hpp"

namespace edgefuse::hal {

struct SimSolid {
  enum Kind : uint8_t { kBox, kCylinder } kind = kBox;
  Pose T_world_solid;          //!< solid-to-world (the solid is centred on its frame's origin)
  Vec3f half_m = Vec3f::Zero();  //!< box: half sizes; cylinder: (radius, radius, half height along z)
  Rgb8 colour;                 //!< flat RGB
  float reflectivity = 0.6f;   //!< ToF reflectivity (0..1)
  float laser_loss = 0;        //!< probability that a laser return on it is lost (dark, shiny)
  int object_id = 0;           //!< objects.txt id, 0 for the bin
};

struct SimHit {
  float t = 0;             //!< distance along the (unit) ray in metres
  Vec3f normal_world;      //!< unit surface normal facing the ray
  int solid = -1;          //!< index in the scene
};

class SimScene {
 public:
  static constexpr int kCapacity = 32;

  //! Adds a solid; false when the scene is full.
  //! \param solid the solid to add
  bool add(const SimSolid& solid);
  int size() const { return count_; }
  const SimSolid& solid(int i) const { return solids_[i]; }
  //! Nearest hit along origin + t * dir, t > 0 (dir unit length).
  //! \param origin ray origin (world)  \param dir unit direction (world)  \param hit receives the hit
  bool intersect(const Vec3f& origin, const Vec3f& dir, SimHit& hit) const;

 private:
  SimSolid solids_[kCapacity];
  float bound_radius_m_[kCapacity];  // bounding sphere about the solid's origin: most rays skip the slab test
  int count_ = 0;
};

//! bin_rig_a's scene (world: z up, origin at the centre of the bin's inner floor).
void default_bin_scene(SimScene& scene);

}  // namespace edgefuse::hal
