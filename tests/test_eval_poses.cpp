// Pose errors of `edgefuse eval poses`: symmetric models (box: discrete, cylinder: continuous) are
// not counted wrong for an equivalent pose; a non-symmetric model is. Uses bin_rig_a's meshes.
#include <cmath>
#include <string>

#include "eval_poses.hpp"
#include "test_support.hpp"

using namespace edgefuse;
using namespace edgefuse::cli;

TEST_GROUP(EvalPoses){};

TEST(EvalPoses, SymmetricModelsUseTheirSymmetries) {
  const std::string dir = edgefuse_test::require_data("bin_rig_a");
  if (dir.empty()) return;
  std::string err;
  EvalModel box, cyl, bracket;
  CHECK_TRUE(load_eval_model(dir + "/models/box.ply", box, err));
  CHECK_TRUE(load_eval_model(dir + "/models/cylinder.ply", cyl, err));
  CHECK_TRUE(load_eval_model(dir + "/models/bracket.ply", bracket, err));
  CHECK_TRUE(box.symmetric());
  CHECK_EQUAL(4u, box.syms.size());  // identity and 180 deg about x, y, z
  CHECK_EQUAL(1u, cyl.cont_axes.size());
  CHECK_FALSE(bracket.symmetric());
  DOUBLES_EQUAL(0.0808, cyl.diameter, 0.002);  // sqrt(40^2 + 70^2) mm
  Pose G = Pose::from_tq(0.1f, 0.02f, 0.03f, 0.1f, 0.2f, 0.3f, 0.9f);
  Pose flip = G;
  flip.R = G.R * Mat3f(Eigen::AngleAxisf(float(M_PI), Vec3f::UnitZ()));
  const PoseErrors eb = pose_errors(box, flip, G);
  DOUBLES_EQUAL(0.0, eb.r_deg, 0.05);
  DOUBLES_EQUAL(0.0, eb.add_mm, 1.5);  // ADD-S: sample spacing
  Pose spin = G;
  spin.R = G.R * Mat3f(Eigen::AngleAxisf(0.7f, Vec3f::UnitZ()));
  DOUBLES_EQUAL(0.0, pose_errors(cyl, spin, G).r_deg, 0.05);
  const PoseErrors en = pose_errors(bracket, flip, G);
  DOUBLES_EQUAL(180.0, en.r_deg, 0.05);
  CHECK(en.add_mm > 10.0);
  Pose shifted = G;
  shifted.t += Vec3f(0.003f, 0.004f, 0.0f);
  DOUBLES_EQUAL(5.0, pose_errors(bracket, shifted, G).t_mm, 1e-3);
  DOUBLES_EQUAL(5.0, pose_errors(bracket, shifted, G).add_mm, 1e-3);
}
