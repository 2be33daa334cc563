// `edgefuse eval poses` and `edgefuse eval segments` (localisation accuracy), and the
// pose-error metrics they use (host code, may allocate).
#pragma once

#include <string>
#include <vector>

#include "edgefuse/math/pose.hpp"

namespace edgefuse::cli {

int cmd_eval_poses(int argc, char** argv);
int cmd_eval_segments(int argc, char** argv);

//! One line of a pose list (`edgefuse localize --out`, a rig set's objects.txt).
struct PoseLine {
  int id = 0;
  Pose T;  //!< T_world_object
  float score = 0;
  std::string model;  //!< empty when the line has none
};
//! Reads `id tx ty tz qx qy qz qw [score] [model]` lines (# comments); an error names file and line.
bool read_pose_lines(const std::string& path, std::vector<PoseLine>& out, std::string& err);

//! A model for evaluation: even surface samples (~1000), diameter, symmetries found by testing
//! rotations about the bounding-box axes through its centre.
struct EvalModel {
  std::vector<Vec3f> pts;
  Vec3f centre = Vec3f::Zero();
  float diameter = 0;
  std::vector<Mat3f> syms;       //!< discrete symmetries (identity first)
  std::vector<Vec3f> cont_axes;  //!< axes of continuous symmetry
  bool symmetric() const { return syms.size() > 1 || !cont_axes.empty(); }
};

//! Reads a PLY mesh (or cloud) and finds its symmetries.
bool load_eval_model(const std::string& path, EvalModel& m, std::string& err);

struct PoseErrors {
  double t_mm;    //!< distance of the model centres
  double r_deg;   //!< rotation error, the smallest over the model's symmetries
  double add_mm;  //!< ADD (ADD-S for a symmetric model)
};
//! Errors of the estimate E against the truth G (both T_world_object).
PoseErrors pose_errors(const EvalModel& m, const Pose& E, const Pose& G);

}  // namespace edgefuse::cli
