// The layout-specific openers behind open_depth_sequence (dataset.cpp detects the layout).
#pragma once

#include <string>
#include <vector>

#include "edgefuse/io/dataset.hpp"
#include "edgefuse/io/rig.hpp"

namespace edgefuse::io::detail {

//! A TUM folder. `rig_sensor` (may be null) supplies intrinsics and the color/amplitude flags;
//! without it camera.toml, or a ../rig.toml sensor named like the folder, gives the intrinsics.
bool open_tum_folder(const std::string& root, const RigSensor* rig_sensor, DepthSequence& seq, std::string& err);

//! A per-frame (7-Scenes) folder.
bool open_per_frame_folder(const std::string& root, DepthSequence& seq, std::string& err);

//! A single frame: depth.png + camera.toml [+ rgb.png].
bool open_single_frame_folder(const std::string& root, DepthSequence& seq, std::string& err);

//! The last path component ("." for an empty one).
std::string base_name(const std::string& path);

}  // namespace edgefuse::io::detail
