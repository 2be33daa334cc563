// Shared pieces of `edgefuse fuse --sensors` and `edgefuse calibrate`: binding each rig sensor to
// its slot of the board's static buffers, staging and pre-filtering a pinhole frame with its
// trust map, and the pair calibration over several still frames.
#pragma once

#include <string>
#include <vector>

#include "core_setup.hpp"
#include "edgefuse/filters/depth_filter_chain.hpp"
#include "edgefuse/fusion/calibrate_pair.hpp"
#include "edgefuse/fusion/fusion_rules.hpp"
#include "edgefuse/io/dataset.hpp"
#include "edgefuse/io/rig.hpp"
#include "edgefuse/sensor/noise_model.hpp"
#include "edgefuse/tracking/pyramid.hpp"
#include "laser_push.hpp"
#include "edgefuse/hal/platform/threads/worker_pool.hpp"

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
  //! Noise gate of the trust map (build_trust_map's sigma_max_m; 0: none): pixels noisier than this
  //! are dropped from the staged depth (no surface, no free space).
  float sigma_max_m = 0.0f;
  //! Noise-aware depth discontinuity (with a trust map only; 0: off, the truncation as always):
  //! a staged frame's DepthFrame::jump_m = jump_sigmas x the median modelled noise of its pixels.
  float jump_sigmas = 0.0f;
  //! DepthFrame::sub_unit_fill_units of its staged frames (8: one full sample; fusion_rules.hpp).
  int sub_unit_fill_units = kWeightUnitsPerSample;
  //! What staging counted (frames staged with a trust map): the push's report and the set's rules.
  struct StageCounts {
    std::size_t staged_pixels = 0;  //!< pixels with depth (after the filters)
    std::size_t gated_pixels = 0;   //!< of those, dropped by the noise gate
    double jump_m_sum = 0.0;        //!< sum of the jump_m set
    std::size_t jump_frames = 0;    //!< frames it was set for
    NoiseMean sigma;                //!< the frames' median modelled noise
  } counts;
  //! Mean of the staged frames' median noise (0 before any frame with a trust map).
  float median_sigma() const { return counts.sigma.mean_m(); }
};

// The noise rules: edgefuse/fusion/fusion_rules.hpp (shared with edgefused).

//! Each camera's median_sigma(), in order (the fusion rules' input).
//! \param cams the set's cameras
std::vector<float> median_sigmas(const std::vector<PinholeSlot>& cams);

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

// --- multi-sensor fusion of a rig set (`edgefuse fuse --sensors`, `edgefuse localize --sensors`)

//! The listed sensors of a rig set, opened for fusion (host I/O side).
struct RigSensors {
  std::vector<PinholeSlot> cams;    //!< pinhole sensors in listed order
  std::vector<io::LineScan> scans;  //!< line scanners in listed order
  std::vector<int> scan_slot;       //!< board slot of each scan
  int ref = -1;                     //!< reference camera: the first listed with colour, else the first pinhole
  int listed = 0;                   //!< number of listed sensors
};

//! Splits "a,b,c" at commas.
std::vector<std::string> split_names(const std::string& s);

//! Opens the listed sensors of the rig set in `folder`.
//! \param folder rig set folder  \param set its rig.toml  \param names sensor names (distinct, known)
//! \param board capacities (slot count)  \param rs opened sensors  \param err error text
//! \param usage set when the error is in the option (exit code 2) rather than in the data
bool open_rig_sensors(const std::string& folder, const io::RigSet& set, const std::vector<std::string>& names,
                      const BoardCapacities& board, RigSensors& rs, std::string& err, bool& usage);

//! Binds every camera to its slot and picks the filters' intermediate image: the depth buffer of a
//! slot no camera uses.
//! \param rs opened sensors  \param core set-up core buffers  \param board capacities
//! \param filter_scratch the spare image  \param err error text
bool bind_rig_sensors(RigSensors& rs, CoreSetup& core, const BoardCapacities& board,
                      ImageView<uint16_t>& filter_scratch, std::string& err);

//! Centres the volume on the reference camera's first view (or on the line scanner's returns).
//! \param rs opened sensors  \param settings volume settings (origin written)  \param err error text
bool place_rig_volume(RigSensors& rs, FuseSettings& settings, std::string& err);

//! Pushes every camera's frames (its ground-truth poses, or the reference camera's pose at the same
//! instant times `mount[c]` where `mounted[c]`), then every line scanner's profiles (own poses).
//! \param rs bound sensors  \param core core with the volume made  \param runner integration threads (null: this one)
//! \param mount T_ref_cam per camera  \param mounted whether to use it
//! \param frames_max frames per camera  \param filter pre-filter the depth  \param colour_ref integrate the
//! reference camera's colour  \param sigma_ref_m trust reference noise (0: equal weights)
//! \param filter_scratch spare image  \param err error text  \param verbose one line per sensor
//! \param laser line scanners: patch registration (laser_push.hpp; default: recorded poses)
bool push_rig_frames(RigSensors& rs, CoreSetup& core, const RowRunner* runner, const std::vector<Pose>& mount,
                     const std::vector<char>& mounted, std::size_t frames_max, bool filter, bool colour_ref,
                     float sigma_ref_m, ImageView<uint16_t> filter_scratch, std::string& err, bool verbose,
                     const LaserPushOptions& laser = LaserPushOptions());

//! The set's sub-unit fill (fusion_rules.hpp default_sub_unit_fill), decided before the
//! push from each camera's first frame (staged as the push will, counters left untouched), set on
//! every camera (PinholeSlot::sub_unit_fill_units).
//! \param rs bound sensors  \param filter pre-filter as the push  \param sigma_ref_m trust reference (0: none, fill 8)
//! \param filter_scratch spare image  \param fill the fill set  \param err error text
bool plan_sub_unit_fill(RigSensors& rs, bool filter, float sigma_ref_m, ImageView<uint16_t> filter_scratch, int& fill,
                        std::string& err);

//! Confidence of a fused surface point: the largest weight of the 8 voxels around it (weight units:
//! 1/8 sample x trust), i.e. how much data supports the surface there.
//! \param volume the space  \param p world point (metres)
int support_weight(const TsdfVolume& volume, const Vec3f& p);

}  // namespace edgefuse::cli
