// The rigid-pair calibration of two rig cameras over a recording (paper Fig. 6; `edgefuse
// calibrate`, `edgefuse fuse --sensors --extrinsics calibrated`): A maps the space through the
// pipeline's Mapper (tracked, or at its recorded poses), B's frames taken at the same instants are
// registered to it (calibrate_pair), and the accepted estimates are averaged.
#pragma once

#include <string>
#include <vector>

#include "edgefuse/fusion/calibrate_pair.hpp"
#include "rig_fusion.hpp"

namespace edgefuse::cli {

//! Pose as "tx ty tz qx qy qz qw" (extrinsics.txt / TUM order).
std::string pose_line(const Pose& T);
//! "tx,ty,tz,rx,ry,rz" (metres, degrees: rotation vector) -> pose.
bool parse_guess(const std::string& text, Pose& T, std::string& err);

struct PairCalibrationRun {
  std::vector<PairCalibrationResult> frames;  //!< one per registered frame of B
  std::vector<int> frame_index;               //!< B's frame of each
  int accepted = 0;
  Pose T_a_b;                                 //!< mean of the accepted frames
  Vec6f spread = Vec6f::Zero();               //!< std. deviation over them (rad, m; B frame)
  Vec6f sigma = Vec6f::Zero();                //!< mean of the frames' covariance sigmas
  std::string first_reason;                   //!< of the first refused frame
  int a_tracked_ok = 0;                       //!< A's frames tracked ok (when tracking)
  float a_pose_error_mm = 0;                  //!< largest distance of A's tracked pose from its ground truth
};

//! What the pair calibration works with.
struct PairCalibrationSetup {
  TsdfVolume* volume = nullptr;         //!< the space (placed, empty)
  ImageView<uint16_t> filter_scratch;   //!< a spare depth image
  ViewCentreScratch centre;             //!< the mapper's centring scratch
  int frames = 0;                       //!< A's frames to use
  Pose guess;                           //!< T_A_B to start from
  PairCalibrationParams params;         //!< calibration thresholds
  bool track_a = true;                  //!< A tracked by ICP from its first recorded pose (else at every recorded pose)
  bool verbose = false;                 //!< one line per frame of B
};

//! Fills the space with A's first frames, then registers B's frames taken at the same instants.
//! \param a sensor A (slot bound)  \param b sensor B (slot bound)  \param setup space and options
//! \param run results  \param err error text
bool run_pair_calibration(RigCamera& a, RigCamera& b, const PairCalibrationSetup& setup, PairCalibrationRun& run,
                          std::string& err);

}  // namespace edgefuse::cli
