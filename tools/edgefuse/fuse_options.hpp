// The volume settings shared by the commands that fuse (fuse, fuse --sensors, track): the build
// board's defaults, then the options --voxel --trunc --volume --threads --frames --origin.
#pragma once

#include <string>

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

}  // namespace edgefuse::cli
