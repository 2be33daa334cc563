// OpenNI2 depth camera (PrimeSense / Asus Xtion / Kinect v1 class): depth in 1 mm or 100 um
// formats, optional colour registered to depth by the device, a device URI ("" = any device,
// "Dummy" = OpenNI2's built-in test device, or a path to an .oni recording).
//
// .oni playback: at the recorded rate, or as fast as processing asks (OpenNI2's "manual" speed:
// each wait hands over the next recorded frame, none dropped); the end of the recording is
// kEndOfStream as soon as the last recorded frame was delivered (or it loops). Debian's OpenNI2 2.2
// player silently drops every frame of a recorded stream that has no cropping property (its
// PlayerStream needs one; a PrimeSense device records it, the Dummy device does not), so such a
// recording is refused at start() with an error saying so instead of timing out forever.
//
// OpenNI2 allocates inside the library for every frame (its frame pool and the driver's); this
// backend copies each frame into the caller's static buffer and allocates nothing itself.
// Device time stamps (microseconds on the device clock) are mapped to the HAL clock by the offset
// seen at the first frame after start(), re-synchronised when they drift by more than 100 ms.
// OpenNI.h stays inside openni2_depth_camera.cpp (pimpl), so users see no platform header.
#pragma once

#include <cstdint>

#include "edgefuse/hal/clock.hpp"
#include "edgefuse/hal/depth_camera.hpp"

namespace edgefuse::hal {

enum class Openni2DepthFormat : uint8_t { k1mm, k100um };

//! What became of colour at the last start(): the backend only delivers colour the device has
//! registered to depth (unregistered colour would paint the wrong voxels), and says why not.
enum class Openni2ColourState : uint8_t {
  kNotRequested,            //!< config.colour = false
  kNoColourSensor,          //!< the device has no colour sensor
  kRegistrationUnsupported, //!< IMAGE_REGISTRATION_DEPTH_TO_COLOR not supported (Dummy, recordings)
  kRegistrationFailed,      //!< supported, but creating/registering/starting the colour stream failed
  kRegistered,              //!< colour frames are registered to depth and delivered
};
//! \param s state  \return short stable text for logs and the status line
const char* to_string(Openni2ColourState s);

struct Openni2CameraConfig {
  const char* name = "xtion";  //!< board device name
  const char* uri = "";        //!< "" any device, "Dummy", or an .oni file path
  int width = 640;             //!< requested depth mode
  int height = 480;
  int fps = 30;
  Openni2DepthFormat format = Openni2DepthFormat::k1mm;
  bool colour = true;          //!< also stream RGB888 registered to depth (when the device has colour)
  PinholeIntrinsics intr;      //!< used when the device reports no field of view (fx = 0: derive from FOV)
  bool playback_fast = false;  //!< .oni: every recorded frame as soon as asked, else at the recorded rate
  bool playback_loop = false;  //!< .oni: start again after the last frame, else kEndOfStream
};

class Openni2DepthCamera final : public DepthCamera {
 public:
  //! \param config device and mode  \param clock HAL clock (stamp mapping)
  Openni2DepthCamera(const Openni2CameraConfig& config, Clock& clock);
  ~Openni2DepthCamera() override;
  Openni2DepthCamera(const Openni2DepthCamera&) = delete;
  Openni2DepthCamera& operator=(const Openni2DepthCamera&) = delete;

  const char* name() const override { return config_.name; }
  int mode_count() const override { return 1; }
  bool mode(int index, DepthMode& mode) const override;
  HalStatus start(int mode_index) override;
  void stop() override;
  PinholeIntrinsics intrinsics() const override { return intr_; }
  HalStatus next_frame(DepthFrame& frame, uint32_t timeout_ms) override;

  //! What went wrong last (names the URI; includes OpenNI's extended error and offered modes).
  const char* last_error() const { return error_; }
  //! Whether colour frames are registered to depth by the device.
  bool colour_registered() const { return colour_registered_; }
  //! Why colour is or is not delivered (set by start(); also logged once to stderr when colour
  //! was requested but cannot be delivered).
  Openni2ColourState colour_state() const { return colour_state_; }
  //! Whether the open device is an .oni recording.
  bool is_recording() const { return recorded_frames_ > 0; }
  //! Depth frames in the open recording (0: a live device).
  int recorded_frames() const { return recorded_frames_; }

 private:
  struct Impl;
  HalStatus fail(HalStatus s, const char* what);
  // start()'s steps on the opened device and depth stream.
  //! An .oni recording: manual speed, repeat as configured, its depth frames counted.
  HalStatus prepare_playback();
  //! Sets the configured depth mode when the device's current one differs; refuses a mode it lacks.
  HalStatus select_depth_mode();
  //! Starts colour registered to depth when asked for and possible; colour_state_ says why not.
  void set_up_colour();
  //! intr_: the board's, else from the reported field of view.
  void set_intrinsics();

  Openni2CameraConfig config_;
  Clock& clock_;
  Impl* impl_ = nullptr;  // created once in the constructor (start-up)
  PinholeIntrinsics intr_;
  bool running_ = false;
  bool colour_registered_ = false;
  Openni2ColourState colour_state_ = Openni2ColourState::kNotRequested;
  int recorded_frames_ = 0;     // > 0: playing an .oni file with that many depth frames
  bool frame_since_start_ = false;  // a frame was read since start() (Dummy stop race)
  bool ended_ = false;          // the last recorded frame was delivered (no loop)
  bool have_dev_ = false;       // recording: last_dev_us_ holds the previous frame's device stamp
  int64_t last_dev_us_ = 0;
  int64_t period_us_ = 33333;   // recording: last device stamp spacing (continues a loop)
  bool have_offset_ = false;
  int64_t offset_us_ = 0;  // HAL clock - device clock
  uint64_t last_stamp_us_ = 0;
  char error_[512] = {};
};

}  // namespace edgefuse::hal
