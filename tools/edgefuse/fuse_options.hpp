// The volume settings shared by the commands that fuse (fuse, fuse --sensors, track): the build
// board's defaults, then the options --voxel --trunc --volume --threads --frames --origin.
#pragma once

#include <string>
#include <vector>

#include "args.hpp"
#include "core_setup.hpp"

namespace edgefuse::cli {

//! The build board's run-time defaults (voxel, truncation, weight cap, threads) and volume capacity.
//! \param settings filled in  \param err why board.toml could not be read
bool board_fuse_settings(FuseSettings& settings, std::string& err);

//! Applies the options that are present (each range-checked); the truncation becomes 4 voxels when
//! only --voxel is given; origin_given tells whether --origin was. Refuses a volume that is not a
//! whole number of bricks and a truncation below one voxel.
//! \param args parsed options  \param settings updated  \param frames_max --frames (else 2^30)
//! \param err the option that was wrong and why
bool apply_fuse_options(const Args& args, FuseSettings& settings, int& frames_max, std::string& err);

//! Sizes the space to what the first frame sees, then places it (centred on the view as
//! centre_on_view() does, unless --origin was given). When less than 90 % of the frame's in-range
//! points fall inside the space: with the board's defaults (no --voxel, --volume or --origin) the
//! voxel grows along a short ladder (4 mm, 5 mm, 1 cm, 2 cm) to the first size whose cube holds 90 %,
//! truncation 4 voxels unless --trunc was given, and one line says so; an explicit space is kept,
//! and when it holds less than half, a warning names the share and the --voxel that would hold
//! 90 %. Refuses when even 2 cm holds too
//! little, naming the --voxel to pass.
//! \param command "track" or "fuse", the prefix of the printed lines
//! \param intr the sensor  \param depth the first frame's raw depth
//! \param T_world_cam the first frame's pose  \param s the settings (voxel, trunc, origin updated)
//! \param depth_path the first frame's file, named when no pixel is in range
//! \param err why the space cannot be sized
bool size_space_to_view(const char* command, const PinholeIntrinsics& intr, const std::vector<uint16_t>& depth,
                        const Pose& T_world_cam, FuseSettings& s, const std::string& depth_path, std::string& err);

}  // namespace edgefuse::cli
