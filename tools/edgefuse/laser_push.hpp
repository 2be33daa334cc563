// Pushing a line scanner's profiles into the space (`edgefuse fuse --sensors ...,laser`), optionally
// registering them first: consecutive profiles form a patch, register_profiles() finds one rigid
// correction of the patch's recorded poses against the space (filled by the cameras, which are
// pushed first, and by the earlier patches), and the patch is integrated at the corrected poses.
// The correction found is carried to the next patch as its start (an encoder or hand-eye error
// is mostly constant over a sweep), so each patch only refines it.
#pragma once

#include <string>

#include "edgefuse/io/rig.hpp"
#include "edgefuse/math/pose.hpp"
#include "edgefuse/pipeline/mapper.hpp"
#include "edgefuse/tsdf/register_profiles.hpp"

namespace edgefuse::cli {

struct LaserPushOptions {
  //! Translation only; a direction counts as constrained above 0.3 % of the strongest (the library's
  //! 1e-4 lets noise "constrain" the in-plane directions of a floor patch, which then slides; the
  //! bin_rig_a sweep pins its weakest direction at 0.3-1 %, a floor patch stays far below).
  static ProfileRegistrationParams defaults() {
    ProfileRegistrationParams p;
    p.translation_only = true;
    p.min_eigen_ratio = 3e-3f;
    p.max_distance_m = 0.0f;
    return p;
  }
  bool register_patches = false;  //!< register each patch against the space before integrating it
  int patch_profiles = 300;       //!< profiles per patch: 30 cm of sweep at 1 mm steps, so that it crosses several
                                  //!< objects' edges (30-profile patches: mostly floor, 1-2 mm wrong; BENCHMARKS)
  float max_rms_m = 0.0f;         //!< a patch whose rms after registration is above this keeps the carried
                                  //!< correction (0: half a voxel)
  ProfileRegistrationParams reg = defaults();  //!< registration thresholds (max_distance_m 0: the truncation / 2)
  bool verbose = false;           //!< one line per patch
};

struct LaserPushStats {
  int profiles = 0;        //!< pushed
  int patches = 0;         //!< registered (tried)
  int accepted = 0;        //!< whose correction was taken
  float mean_rms_m = 0;    //!< over the accepted patches, after registration
  Pose last_correction;    //!< the carried world-frame correction at the end
  float max_step_mm = 0;   //!< largest change of the correction between patches (mm at the patch)
  Pose first_pose_used;    //!< the first profile's pose as integrated (offset and correction applied)
};

//! Maps the profiles of `scan` (at its recorded poses, registered per patch when asked) through the
//! mapper (Mapper::map_profile, the scanner's trust from kLineScannerSigmaM).
//! \param mapper the mapper (cameras already pushed)  \param scan the line scanner's data
//! \param tan_table storage for the scanner's tan table (scan.sensor.line.beams real_t values)
//! \param tan_capacity its capacity in values  \param options registration  \param stats what happened
//! \param err error text
bool push_line_scan(Mapper& mapper, const io::LineScan& scan, void* tan_table, int tan_capacity,
                    const LaserPushOptions& options, LaserPushStats& stats, std::string& err);

}  // namespace edgefuse::cli
