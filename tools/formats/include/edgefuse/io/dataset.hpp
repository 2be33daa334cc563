// One reader for every depth-sequence layout of FORMATS.md, so tools and tests replay them alike:
//   - rig set (rig.toml): the named pinhole sensor's folder, a TUM sequence with rig.toml intrinsics;
//   - TUM folder (depth.txt [+ rgb.txt, amplitude.txt, groundtruth.txt] + camera.toml, or a rig
//     sensor folder whose ../rig.toml describes it); colour, amplitude and pose of a frame are the
//     ones nearest in time, if closer than 0.02 s (as TUM's associate.py, without its one-to-one rule);
//   - per-frame folder (7-Scenes: frame-NNNNNN.depth.png [+ .pose.txt], camera.toml or
//     camera-intrinsics.txt); the stamp is the frame number; 7-Scenes colour is not registered and
//     is not listed;
//   - single frame folder (depth.png + camera.toml [+ rgb.png]), no pose.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "edgefuse/core/image.hpp"
#include "edgefuse/io/camera_toml.hpp"
#include "edgefuse/math/pose.hpp"
#include "edgefuse/sensor/pinhole.hpp"

namespace edgefuse::io {

struct FrameRef {
  double stamp_s = 0;
  std::string depth_path;      //!< 16-bit PNG, value / intr.depth_scale = z-depth in metres
  std::string colour_path;     //!< registered 8-bit colour, empty when none
  std::string amplitude_path;  //!< 16-bit ToF amplitude, empty when none
  bool has_pose = false;       //!< ground truth found (within 0.02 s for TUM layouts)
  Pose T_world_cam;            //!< sensor-to-world when has_pose
};

enum class SequenceLayout { kTum, kRigSensor, kPerFrame, kSingleFrame };

struct DepthSequence {
  std::string root;         //!< the folder holding the frames' files
  std::string sensor_name;  //!< rig sensor name; otherwise the folder's name
  SequenceLayout layout = SequenceLayout::kTum;
  PinholeIntrinsics intr;
  CameraDistortion distortion;     //!< from camera.toml when given (the core ignores it)
  bool colour_registered = false;  //!< colour_path images are pixel-aligned with depth
  std::vector<FrameRef> frames;    //!< in time order
};

//! Detects the layout of `path` (a folder) and lists its frames. `sensor` selects a rig sensor
//! (empty: the first pinhole sensor of rig.toml); it must be empty for other layouts.
//! Checks the lists and the intrinsics; the images themselves are read by load_depth/load_colour.
bool open_depth_sequence(const std::string& path, const std::string& sensor, DepthSequence& seq,
                         std::string& err);

//! Reads a frame's depth and checks its size against the intrinsics.
bool load_depth(const FrameRef& frame, const PinholeIntrinsics& intr, std::vector<uint16_t>& depth,
                std::string& err);
//! Reads a frame's colour (must exist) and checks its size against the intrinsics.
bool load_colour(const FrameRef& frame, const PinholeIntrinsics& intr, std::vector<Rgb8>& colour,
                 std::string& err);
//! Reads a frame's ToF amplitude (must exist) and checks its size against the intrinsics.
bool load_amplitude(const FrameRef& frame, const PinholeIntrinsics& intr, std::vector<uint16_t>& amplitude,
                    std::string& err);

const char* to_string(SequenceLayout layout);

}  // namespace edgefuse::io
