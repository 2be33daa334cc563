// Push and raycast of a line scanner profile (paper eq. 6-8).
//
// Integration: only voxels whose centre lies within `plane_band_m` (default half a voxel) of the
// profile's scan plane are updated, so a sweep in steps of about a voxel writes each voxel from
// the one or two profiles that pass through it (eq. 8: "a voxel belongs to the profile taken where
// the scanner's y equals the voxel's y"). For such a voxel p' (sensor frame), its beam is found
// from p'.x / p'.z in the tan table (line_scanner.hpp), the measured range m is interpolated
// between the two neighbouring beams (no update across a range jump larger than the truncation:
// nearest beam instead, as the pinhole kernel does at silhouettes), and the signed distance along
// the beam is d = m - |p'| with |p'| the voxel's range in the scan plane (eq. 1). The update is the
// pinhole kernel's: Bylow weight (weight.hpp) times the sensor trust, running average, cap.
//
// Only the voxels of the fan's bounding box are visited (bricks in order, so the brick flags and
// the near-surface dilation of the raycast stay exact). Static memory only: no allocation.
//
// Raycast (sensor-corresponding model of a profile): each beam is marched from min to max range
// through the trilinear TSDF, stepping by the distance (at least half a voxel), and the first
// + to - crossing is refined by one regula falsi step. The result is a profile of model ranges
// (0 = no surface), directly comparable with a measured profile (and so registrable).
#pragma once

#include "edgefuse/core/status.hpp"
#include "edgefuse/math/pose.hpp"
#include "edgefuse/sensor/line_scanner.hpp"
#include "edgefuse/tsdf/volume.hpp"

namespace edgefuse {

//! Largest trust of a profile sample: 255 weight units (the weight's storage) / 8 per full sample.
//! A laser profile scanner (20 um) is ~50x finer than sigma_ref = half a 2 mm voxel: its inverse-
//! variance weight (2500) is far beyond what a uint8 weight holds, so it gets the most there is:
//! one sample then carries ~3/4 of a voxel that 20 camera frames filled (~80 units).
inline constexpr float kProfileTrustMax = 255.0f / 8.0f;

struct ProfilePushStats {
  int voxels_updated = 0;  //!< voxels written by this profile
  int bricks_touched = 0;  //!< bricks holding them
};

//! Integrates one profile.
//! \param volume the space
//! \param model the scanner (validated)
//! \param tables its tan table (built for model, kernel scalar)
//! \param ranges_m model.beams ranges in metres along each beam, 0 = no return
//! \param T_world_sensor pose of the scanner for this profile
//! \param plane_band_m half-thickness of the slab around the scan plane that is updated (0: half a voxel)
//! \param trust sensor trust factor in (0, kProfileTrustMax] (noise_model.hpp): above 1 for a scanner
//!        finer than the reference noise, so that where it measured it dominates the cameras' average
//!        (a full-trust sample weighs 8 units, this one up to 255)
//! \param stats optional counts
template <class Real>
Status integrate_profile(TsdfVolume& volume, const LineScannerModel& model, const LineScannerTables<Real>& tables,
                         const float* ranges_m, const Pose& T_world_sensor, float plane_band_m = 0.0f,
                         float trust = 1.0f, ProfilePushStats* stats = nullptr);

//! Raycasts the profile the scanner would measure at a pose.
//! \param volume the space
//! \param model the scanner (validated)
//! \param T_world_sensor pose
//! \param ranges_out_m model.beams model ranges (0 = no surface on that beam within the range limits)
template <class Real>
Status raycast_profile(const TsdfVolume& volume, const LineScannerModel& model, const Pose& T_world_sensor,
                       float* ranges_out_m);

}  // namespace edgefuse
