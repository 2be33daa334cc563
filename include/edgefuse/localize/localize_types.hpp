// Types of object localisation (model-based poses by point pair features, model-free segments).
// Everything lives in fixed-capacity tables carved from the board's static memory map.
#pragma once

#include <cstddef>
#include <cstdint>

#include "edgefuse/core/image.hpp"
#include "edgefuse/math/pose.hpp"

namespace edgefuse {

//! Largest |coordinate| (metres) of a point the localiser takes, in the scene or in a model: far
//! beyond any robot cell, and small enough that its neighbour grids' integer cells (down to the
//! smallest grid cell, kLocalizeGridCellMinM) stay far inside int32. Points beyond it (garbage in a
//! cloud file, e.g. 1e30) are skipped like non-finite ones instead of overflowing those cells.
inline constexpr float kLocalizeCoordMaxM = 1000.0f;
//! Smallest neighbour-grid cell set_scene accepts (0.1 mm): 1 km / 0.1 mm = 1e7 cells < 2^31.
inline constexpr float kLocalizeGridCellMinM = 1e-4f;

//! True for a point the localiser takes: finite, every coordinate within +-kLocalizeCoordMaxM.
//! \param p position in metres
inline bool localizable(const Vec3f& p) {
  return p.allFinite() && p.cwiseAbs().maxCoeff() <= kLocalizeCoordMaxM;
}

//! A surface sample: position and unit outward normal (model frame or world frame).
struct OrientedPoint {
  Vec3f p;
  Vec3f n;
};

//! A scene point: world position, outward normal, and the index of the input point it came from
//! (for organised inputs: v * width + u, so labels can be written back per pixel).
struct ScenePoint {
  Vec3f p;
  Vec3f n;
  uint32_t source;
  Rgba8 colour;  //!< a = 0: no colour
};

inline constexpr int kModelNameMax = 40;
inline constexpr int kPpfAngleBins = 30;          //!< 12 degree steps (Drost et al.)
inline constexpr uint32_t kPpfBuckets = 1u << 15; //!< hash buckets per model
inline constexpr uint32_t kGridBuckets = 1u << 18;  //!< scene nearest-neighbour grid buckets
inline constexpr int kClustersPerModel = 32;      //!< pose clusters refined and verified per model
//! PPF vote accumulators (the references are voted in this many chunks, one accumulator each, over
//! the caller's threads; a fixed count, so the chunking and the results do not depend on threads).
inline constexpr int kVoteAccumulators = 4;
//! Stable resting faces kept per model (bin-picking prior: a part lying on the bin floor rests on
//! one of them; hypotheses for such parts come from a 3-DOF search, see rest_pose.cpp).
inline constexpr int kRestFacesMax = 8;

//! One entry of a model's point pair feature table: the quantised feature (for collision checks),
//! the model reference point and its angle alpha_m (quantised to int16 over [-pi, pi)).
struct PpfEntry {
  uint32_t key;
  uint16_t ref;
  int16_t alpha_q;
};

//! A model as stored at start-up.
struct ModelInfo {
  char name[kModelNameMax] = {};  //!< base name of its file (for the output)
  float diameter_m = 0;      //!< largest distance between two surface samples
  float ppf_step_m = 0;      //!< sampling and distance quantisation of the PPF table
  float dense_step_m = 0;    //!< spacing of the dense samples (refinement / verification)
  Vec3f half_extent_m = Vec3f::Zero();  //!< half the bounding box (object frame)
  Vec3f centre_m = Vec3f::Zero();       //!< bounding-box centre (object frame)
  uint32_t dense_count = 0;  //!< dense samples (ICP, verification)
  uint32_t ppf_count = 0;    //!< sparse samples (PPF table)
  uint32_t entry_count = 0;  //!< PPF table entries
  int rest_count = 0;        //!< stable resting faces found at start-up (largest support first)
  Vec3f rest_down[kRestFacesMax];  //!< per resting face: the unit direction (object frame) that points at the floor
};

//! A pose hypothesis from one scene reference point's vote peak.
struct PoseCandidate {
  Pose T_world_object;
  float votes;
  int model;
};

//! What the localiser knows about the scene besides its points.
struct SceneContext {
  Vec3f viewpoint_m = Vec3f::Zero();  //!< where the sensor(s) looked from (visibility of model points)
  Vec3f up = Vec3f(0, 0, 1);          //!< away from the bin floor (set by bin detection)
  float floor_offset = 0;             //!< floor plane: up . x + floor_offset = 0
  bool has_floor = false;
  int walls = 0;                      //!< detected bin walls (planes with inward normals)
  Vec3f wall_n[4];                    //!< unit normal pointing into the bin
  float wall_d[4];                    //!< wall plane: wall_n . x + wall_d = 0
  Vec3f floor_centre_m = Vec3f::Zero();  //!< centre of the floor points
  Vec3f floor_axis[2];                //!< in-plane principal axes of the floor points
  float floor_lo[2] = {0, 0};         //!< extent of the floor along each axis (robust bounds)
  float floor_hi[2] = {0, 0};
};

//! A bin known from configuration (instead of detection): an open box whose inner floor is the
//! bin frame's z = 0 plane (z up, into the bin's opening), centred on the bin frame's origin.
struct BinGeometry {
  Pose T_world_bin;           //!< bin frame to world
  float inner_x_m = 0;        //!< inner floor length along the bin's x axis
  float inner_y_m = 0;        //!< ... and along its y axis
};

//! One result: a model instance or a model-free segment, in picking order.
struct LocalizedObject {
  int model = -1;           //!< model index, or -1 for a segment
  int segment = 0;          //!< segment label (model-free mode), 0 otherwise
  Pose T_world_object;      //!< model frame (or segment box frame: axes = box axes) to world
  float score = 0;          //!< model: share of the visible model surface the scene supports; segment: 1
  float residual_m = 0;     //!< RMS point-to-plane distance of the supported points
  float free_space = 0;     //!< share of model samples in space the TSDF knows is empty
  Vec3f grasp_m = Vec3f::Zero();     //!< grasp point on the top surface, world
  Vec3f approach = Vec3f(0, 0, -1);  //!< unit direction the gripper moves along (into the surface)
  Vec3f size_m = Vec3f::Zero();      //!< box edge lengths (model: bounding box; segment: oriented box)
  float top_m = 0;                   //!< height of the highest supported point above the floor
  uint32_t support = 0;              //!< scene points explained (segment: points in it)
};

}  // namespace edgefuse
