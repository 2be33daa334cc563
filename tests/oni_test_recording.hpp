// Makes a small .oni recording for the openni2 backend's playback tests, through OpenNI2's own
// Recorder on its built-in Dummy device (no hardware, nothing committed: written to a temp dir).
//
// Why the patch step: Debian's OpenNI2 2.2 player (libOniFile) silently drops every frame of a
// recorded stream without the "xnCropping" property (PlayerStream::OnNewDataCallback returns when
// the property is missing), and the Recorder writes it only for streams that support cropping —
// a PrimeSense/Xtion does, the Dummy does not. add_cropping_record() writes the property as a
// PrimeSense recording carries it (cropping disabled) in place of two records the player ignores,
// so no file offset moves (seek table, undo chain).
#pragma once

#include <string>

namespace edgefuse_test {

//! Records depth frames of OpenNI2's Dummy device (320x240 DEPTH_1_MM at 30 fps).
//! \param path .oni file to write  \param frames frames to wait for while recording
//! \param recorded out: depth frames the recording holds  \return "" or what failed
std::string record_dummy_oni(const std::string& path, int frames, int& recorded);

//! Adds the (disabled) cropping property a PrimeSense recording has. \param path .oni file
//! \return "" or what failed
std::string add_cropping_record(const std::string& path);

//! A fresh temporary directory (mkdtemp under $TMPDIR or /tmp); "" on failure.
std::string make_temp_dir();

}  // namespace edgefuse_test
