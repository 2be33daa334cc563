// Shared pieces of `edgefuse fuse --sensors` and `edgefuse calibrate`: binding each rig sensor to
// its slot of the board's static buffers, staging and pre-filtering a pinhole frame with its
// trust map, and the pair calibration over several still frames.
#pragma once

#include <string>
#include <vector>

#include "core_setup.hpp"
#include "edgefuse/filters/depth_filter_chain.hpp"
#include "edgefuse/fusion/calibrate_pair.hpp"
#include "edgefuse/io/dataset.hpp"
#include "edgefuse/io/rig.hpp"
#include "edgefuse/sensor/noise_model.hpp"
#include "edgefuse/tracking/pyramid.hpp"

namespace edgefuse::cli {

//! One pinhole sensor of a rig bound to slot `slot` of the board's per-sensor buffers.
struct PinholeSlot {
  io::DepthSequence seq;
  int slot = 0;
  bool tof = false;                  //!< has amplitude images: ToF filters and noise model
  ImageView<real_t> ray_norms;
  FrameScratch scratch;
  RaycastMaps maps;
  ImageView<uint16_t> depth;         //!< staged (and filtered) depth
  ImageView<Rgb8> colour;            //!< staged colour
  DepthFilterChain<real_t> filters;
  NoiseModel noise;
  ImageView<uint8_t> trust;          //!< the slot's trust map (memory map region kTrustMaps)
  std::vector<uint16_t> load_depth, load_amplitude;  //!< file staging (host I/O)
  std::vector<Rgb8> load_colour;

  //! Binds slot buffers; checks the image against the board.
  bool bind(CoreBuffers& b, const BoardCapacities& board, int slot_index, std::string& err);
  //! Loads frame i: depth (pre-filtered when `filter`), colour when `with_colour` and present,
  //! trust map (sigma_ref_m > 0) into `frame`.
  bool stage(std::size_t i, bool filter, bool with_colour, float sigma_ref_m, ImageView<uint16_t> filter_scratch,
             DepthFrame& frame, std::string& err);
};

//! Index of the frame of `seq` whose stamp is nearest to stamp_s (within 0.02 s), or -1.
int frame_near(const io::DepthSequence& seq, double stamp_s);

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

//! A's tracking buffers: when given, A is tracked by ICP against its own model (paper Fig. 3) from
//! its first ground-truth pose instead of being placed at every ground-truth pose.
struct TrackingBuffers {
  FramePyramid<real_t>* pyramid = nullptr;
  IcpWorkspace<real_t> ws;
};

//! Fills the (empty) volume with A's first `frames` frames at A's poses (or tracked: track_a), then registers B's
//! frames taken at the same instants (calibrate_pair, starting from `guess` each time).
//! \param a sensor A (slot bound, volume made)  \param b sensor B (slot bound)
//! \param volume the space  \param pyramid B's frame pyramid  \param ws B's ICP row sums
//! \param filter_scratch a spare depth image  \param frames frames to use  \param guess T_A_B start
//! \param params calibration thresholds  \param run results  \param err error text
//! \param verbose print one line per frame  \param track_a A's tracking buffers (null: A's ground-truth poses)
bool run_pair_calibration(PinholeSlot& a, PinholeSlot& b, TsdfVolume& volume, FramePyramid<real_t>& pyramid,
                          const IcpWorkspace<real_t>& ws, ImageView<uint16_t> filter_scratch, int frames,
                          const Pose& guess, const PairCalibrationParams& params, PairCalibrationRun& run,
                          std::string& err, bool verbose, const TrackingBuffers* track_a = nullptr);

}  // namespace edgefuse::cli
