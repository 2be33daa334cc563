// Parsing of "tx ty tz qx qy qz qw" token groups, shared by trajectories, objects.txt and
// extrinsics.txt.
#pragma once

#include <string>
#include <string_view>

#include "edgefuse/math/pose.hpp"

namespace edgefuse::io::detail {

//! Parses 7 tokens into a pose. The quaternion must be finite with norm within 1 % of 1 (a wrong
//! column order or a truncated number shows up here); `why` says what is wrong otherwise.
bool pose_from_tq_tokens(const std::string_view* tok, Pose& T, std::string& why);

}  // namespace edgefuse::io::detail
