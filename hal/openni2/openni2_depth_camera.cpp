#include "edgefuse/hal/openni2/openni2_depth_camera.hpp"

#include <OpenNI.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <mutex>
#include <thread>

namespace edgefuse::hal {

namespace {

// OpenNI::initialize() is process-wide and reference counted by us (shutdown at the last user).
std::mutex g_init_mutex;
int g_init_users = 0;

bool acquire_openni(char* err, std::size_t n) {
  std::lock_guard<std::mutex> lock(g_init_mutex);
  if (g_init_users == 0 && openni::OpenNI::initialize() != openni::STATUS_OK) {
    std::snprintf(err, n, "OpenNI2 initialize: %s", openni::OpenNI::getExtendedError());
    return false;
  }
  ++g_init_users;
  return true;
}

void release_openni() {
  std::lock_guard<std::mutex> lock(g_init_mutex);
  if (g_init_users > 0 && --g_init_users == 0) openni::OpenNI::shutdown();
}

openni::PixelFormat to_oni(Openni2DepthFormat f) {
  return f == Openni2DepthFormat::k100um ? openni::PIXEL_FORMAT_DEPTH_100_UM : openni::PIXEL_FORMAT_DEPTH_1_MM;
}

}  // namespace

const char* to_string(Openni2ColourState s) {
  switch (s) {
    case Openni2ColourState::kNotRequested: return "not requested";
    case Openni2ColourState::kNoColourSensor: return "no colour sensor";
    case Openni2ColourState::kRegistrationUnsupported: return "registration to depth unsupported";
    case Openni2ColourState::kRegistrationFailed: return "registration to depth failed";
    case Openni2ColourState::kRegistered: return "registered to depth";
  }
  return "unknown";
}

struct Openni2DepthCamera::Impl {
  bool initialised = false;
  openni::Device device;
  openni::VideoStream depth;
  openni::VideoStream colour;
  bool has_colour = false;
  openni::VideoFrameRef depth_frame;
  openni::VideoFrameRef colour_frame;
};

Openni2DepthCamera::Openni2DepthCamera(const Openni2CameraConfig& config, Clock& clock)
    : config_(config), clock_(clock), impl_(new Impl) {}

Openni2DepthCamera::~Openni2DepthCamera() {
  stop();
  delete impl_;
}

bool Openni2DepthCamera::mode(int index, DepthMode& m) const {
  if (index != 0) return false;
  m.width = config_.width;
  m.height = config_.height;
  m.fps = config_.fps;
  m.depth_scale = config_.format == Openni2DepthFormat::k100um ? 10000.0f : 1000.0f;
  m.colour = config_.colour;
  m.amplitude = false;
  return true;
}

HalStatus Openni2DepthCamera::fail(HalStatus s, const char* what) {
  const std::size_t used = std::strlen(error_);
  if (used == 0)
    std::snprintf(error_, sizeof(error_), "openni2 '%s': %s: %s", config_.uri, what,
                  openni::OpenNI::getExtendedError());
  stop();
  return s;
}

HalStatus Openni2DepthCamera::prepare_playback() {
  Impl& d = *impl_;
  openni::PlaybackControl* pc = d.device.getPlaybackControl();
  if (!pc) return fail(HalStatus::kIoError, "no playback control for the recording");
  // Manual speed (-1): each wait hands over the next frame, so "as fast as possible" drops none
  // (speed 0 would race ahead and keep only the newest frame).
  if (pc->setSpeed(config_.playback_fast ? -1.0f : 1.0f) != openni::STATUS_OK ||
      pc->setRepeatEnabled(config_.playback_loop) != openni::STATUS_OK)
    return fail(HalStatus::kIoError, "set playback speed/repeat");
  recorded_frames_ = pc->getNumberOfFrames(d.depth);
  if (recorded_frames_ <= 0) return fail(HalStatus::kBadFrame, "recording holds no depth frames");
  OniCropping crop;  // OpenNI2 2.2's player drops every frame of a stream without it
  int crop_size = sizeof(crop);
  if (d.depth.getProperty(openni::STREAM_PROPERTY_CROPPING, &crop, &crop_size) != openni::STATUS_OK)
    return fail(HalStatus::kBadFrame,
                "recording has no cropping property (recorded from a device without cropping, e.g. "
                "Dummy); OpenNI2 2.2's player would drop every frame of it");
  return HalStatus::kOk;
}

HalStatus Openni2DepthCamera::select_depth_mode() {
  Impl& d = *impl_;
  // Find the requested mode among the sensor's; set it only when it differs from the current one
  // (the Dummy device and .oni playback refuse setVideoMode).
  const openni::Array<openni::VideoMode>& modes = d.depth.getSensorInfo().getSupportedVideoModes();
  bool found = false;
  for (int i = 0; i < modes.getSize(); ++i) {
    const openni::VideoMode& m = modes[i];
    if (m.getResolutionX() == config_.width && m.getResolutionY() == config_.height && m.getFps() == config_.fps &&
        m.getPixelFormat() == to_oni(config_.format)) {
      found = true;
      const openni::VideoMode cur = d.depth.getVideoMode();
      if (cur.getResolutionX() != m.getResolutionX() || cur.getResolutionY() != m.getResolutionY() ||
          cur.getFps() != m.getFps() || cur.getPixelFormat() != m.getPixelFormat()) {
        if (d.depth.setVideoMode(m) != openni::STATUS_OK) return fail(HalStatus::kIoError, "set depth mode");
      }
    }
  }
  if (found) return HalStatus::kOk;
  int n = std::snprintf(error_, sizeof(error_), "openni2 '%s': no depth mode %dx%d@%d %s; offered:", config_.uri,
                        config_.width, config_.height, config_.fps,
                        config_.format == Openni2DepthFormat::k100um ? "100um" : "1mm");
  for (int i = 0; i < modes.getSize() && n > 0 && std::size_t(n) < sizeof(error_); ++i)
    n += std::snprintf(error_ + n, sizeof(error_) - std::size_t(n), " %dx%d@%d/fmt%d", modes[i].getResolutionX(),
                       modes[i].getResolutionY(), modes[i].getFps(), int(modes[i].getPixelFormat()));
  return fail(HalStatus::kInvalidArgument, "mode");
}

void Openni2DepthCamera::set_up_colour() {
  Impl& d = *impl_;
  // Colour registered to depth: only when the device can register (else colour is not delivered,
  // since unregistered colour would paint the wrong voxels).
  colour_registered_ = false;
  const Openni2ColourState before = colour_state_;
  if (!config_.colour) {
    colour_state_ = Openni2ColourState::kNotRequested;
  } else if (!d.device.hasSensor(openni::SENSOR_COLOR)) {
    colour_state_ = Openni2ColourState::kNoColourSensor;
  } else if (!d.device.isImageRegistrationModeSupported(openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR)) {
    colour_state_ = Openni2ColourState::kRegistrationUnsupported;
  } else {
    if (d.colour.create(d.device, openni::SENSOR_COLOR) == openni::STATUS_OK &&
        d.device.setImageRegistrationMode(openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR) == openni::STATUS_OK) {
      d.device.setDepthColorSyncEnabled(true);
      d.has_colour = d.colour.start() == openni::STATUS_OK;
      colour_registered_ = d.has_colour;
    }
    colour_state_ = colour_registered_ ? Openni2ColourState::kRegistered : Openni2ColourState::kRegistrationFailed;
  }
  // Say once (not at every reopen) why colour that was asked for is not delivered.
  if (config_.colour && !colour_registered_ && colour_state_ != before)
    std::fprintf(stderr, "openni2 '%s' (%s): colour requested but not delivered: %s; depth only\n", config_.uri,
                 config_.name, to_string(colour_state_));
}

void Openni2DepthCamera::set_intrinsics() {
  // The board's, else from the reported field of view (centred principal point).
  intr_ = config_.intr;
  intr_.width = config_.width;
  intr_.height = config_.height;
  intr_.depth_scale = config_.format == Openni2DepthFormat::k100um ? 10000.0f : 1000.0f;
  if (intr_.fx > 0) return;
  float hfov = impl_->depth.getHorizontalFieldOfView(), vfov = impl_->depth.getVerticalFieldOfView();
  if (!(hfov > 0.1f) || !(vfov > 0.1f)) {  // not reported (Dummy, some recordings): Xtion's 58 x 45 deg
    hfov = 58.0f * 3.14159265f / 180.0f;
    vfov = 45.0f * 3.14159265f / 180.0f;
  }
  intr_.fx = 0.5f * float(config_.width) / std::tan(0.5f * hfov);
  intr_.fy = 0.5f * float(config_.height) / std::tan(0.5f * vfov);
  intr_.cx = 0.5f * float(config_.width) - 0.5f;
  intr_.cy = 0.5f * float(config_.height) - 0.5f;
}

HalStatus Openni2DepthCamera::start(int mode_index) {
  if (mode_index != 0) return HalStatus::kInvalidArgument;
  stop();
  error_[0] = 0;
  if (!acquire_openni(error_, sizeof(error_))) return HalStatus::kIoError;
  impl_->initialised = true;
  Impl& d = *impl_;
  const char* uri = config_.uri && config_.uri[0] ? config_.uri : openni::ANY_DEVICE;
  if (d.device.open(uri) != openni::STATUS_OK) return fail(HalStatus::kNoDevice, "open");
  if (d.depth.create(d.device, openni::SENSOR_DEPTH) != openni::STATUS_OK)
    return fail(HalStatus::kIoError, "create depth stream");
  recorded_frames_ = 0;
  ended_ = false;
  if (d.device.isFile()) {
    const HalStatus s = prepare_playback();
    if (s != HalStatus::kOk) return s;
  }
  const HalStatus s = select_depth_mode();
  if (s != HalStatus::kOk) return s;
  set_up_colour();
  set_intrinsics();
  if (d.depth.start() != openni::STATUS_OK) return fail(HalStatus::kIoError, "start depth stream");
  running_ = true;
  frame_since_start_ = false;
  have_offset_ = false;
  have_dev_ = false;
  period_us_ = 1000000 / (config_.fps > 0 ? config_.fps : 30);
  return HalStatus::kOk;
}

void Openni2DepthCamera::stop() {
  if (!impl_ || !impl_->initialised) return;
  Impl& d = *impl_;
  const bool was_streaming = d.depth.isValid();
  const bool dummy = config_.uri && std::strcmp(config_.uri, "Dummy") == 0;
  // The Dummy's frame thread sets its own "running" flag when it first runs: a stop() before
  // that is overwritten and the thread never ends. One frame proves it is running.
  if (dummy && was_streaming && !frame_since_start_) {
    openni::VideoStream* streams[] = {&d.depth};
    int ready = -1;
    if (openni::OpenNI::waitForAnyStream(streams, 1, &ready, 2000) == openni::STATUS_OK)
      d.depth.readFrame(&d.depth_frame);
  }
  d.depth_frame.release();
  d.colour_frame.release();
  if (d.has_colour) d.colour.stop();
  if (d.depth.isValid()) d.depth.stop();
  // OpenNI2's Dummy driver does not join its frame thread on stop(): destroying the stream while
  // that thread sleeps its 33 ms frame period crashes. Two periods are enough on an idle machine;
  // the Dummy gets nine (a loaded 2-core host deschedules the thread for longer). Real devices
  // and recordings join their threads; the short wait is harmless there.
  if (was_streaming) std::this_thread::sleep_for(std::chrono::milliseconds(dummy ? 300 : 100));
  if (d.colour.isValid()) d.colour.destroy();
  if (d.depth.isValid()) d.depth.destroy();
  d.has_colour = false;
  if (d.device.isValid()) d.device.close();
  release_openni();
  d.initialised = false;
  running_ = false;
}

HalStatus Openni2DepthCamera::next_frame(DepthFrame& frame, uint32_t timeout_ms) {
  if (!running_) return HalStatus::kNotStarted;
  if (!frame.fits(config_.width, config_.height)) return HalStatus::kInvalidArgument;
  Impl& d = *impl_;
  if (ended_) return HalStatus::kEndOfStream;
  openni::VideoStream* streams[] = {&d.depth};
  int ready = -1;
  const openni::Status w = openni::OpenNI::waitForAnyStream(streams, 1, &ready, int(timeout_ms));
  if (w == openni::STATUS_TIME_OUT) return HalStatus::kTimeout;
  if (w != openni::STATUS_OK) {
    std::snprintf(error_, sizeof(error_), "openni2 '%s': wait: %s", config_.uri, openni::OpenNI::getExtendedError());
    return d.device.isValid() ? HalStatus::kIoError : HalStatus::kNoDevice;
  }
  if (d.depth.readFrame(&d.depth_frame) != openni::STATUS_OK || !d.depth_frame.isValid()) {
    std::snprintf(error_, sizeof(error_), "openni2 '%s': readFrame: %s", config_.uri,
                  openni::OpenNI::getExtendedError());
    return HalStatus::kIoError;
  }
  frame_since_start_ = true;
  const openni::VideoFrameRef& f = d.depth_frame;
  const openni::PixelFormat pf = f.getVideoMode().getPixelFormat();
  if (f.getWidth() != config_.width || f.getHeight() != config_.height ||
      (pf != openni::PIXEL_FORMAT_DEPTH_1_MM && pf != openni::PIXEL_FORMAT_DEPTH_100_UM) ||
      f.getStrideInBytes() < config_.width * 2 || f.getDataSize() < f.getStrideInBytes() * (config_.height - 1) + config_.width * 2) {
    std::snprintf(error_, sizeof(error_), "openni2 '%s': frame %dx%d format %d stride %d size %d does not match the mode",
                  config_.uri, f.getWidth(), f.getHeight(), int(pf), f.getStrideInBytes(), f.getDataSize());
    return HalStatus::kBadFrame;
  }
  const uint8_t* src = static_cast<const uint8_t*>(f.getData());
  for (int v = 0; v < config_.height; ++v)
    std::memcpy(frame.depth + std::size_t(v) * std::size_t(config_.width),
                src + std::size_t(v) * std::size_t(f.getStrideInBytes()), std::size_t(config_.width) * 2u);
  frame.width = config_.width;
  frame.height = config_.height;
  frame.depth_scale = pf == openni::PIXEL_FORMAT_DEPTH_100_UM ? 10000.0f : 1000.0f;
  frame.has_amplitude = false;
  frame.sequence = uint32_t(f.getFrameIndex());
  // Device microseconds -> HAL clock. A live device is re-synchronised when it drifts; a recording
  // keeps its recorded spacing (played fast, its stamps run ahead of the clock, as replay's do).
  const uint64_t now = clock_.now_us();
  const int64_t dev = int64_t(f.getTimestamp());
  if (!have_offset_ || (recorded_frames_ == 0 && std::llabs(int64_t(now) - (dev + offset_us_)) > 100000)) {
    offset_us_ = int64_t(now) - dev;
    have_offset_ = true;
  }
  if (recorded_frames_ > 0 && dev + offset_us_ <= int64_t(last_stamp_us_)) {
    // A recording played again (loop or reopen) after its fast playback ran ahead of the clock:
    // continue one recorded frame period after the last stamp.
    offset_us_ = int64_t(last_stamp_us_) + period_us_ - dev;
  }
  if (recorded_frames_ > 0 && have_dev_ && dev > last_dev_us_) period_us_ = dev - last_dev_us_;
  last_dev_us_ = dev;
  have_dev_ = true;
  uint64_t stamp = uint64_t(dev + offset_us_);
  if (stamp <= last_stamp_us_) stamp = last_stamp_us_ + 1;
  frame.stamp_us = stamp;
  last_stamp_us_ = stamp;
  // The last recorded frame: the next call reports the end instead of waiting for nothing.
  if (recorded_frames_ > 0 && !config_.playback_loop && f.getFrameIndex() >= recorded_frames_) ended_ = true;
  // Newest colour frame, if one is ready (registered: same size as depth).
  frame.has_colour = false;
  if (d.has_colour && frame.colour) {
    openni::VideoStream* cs[] = {&d.colour};
    int ci = -1;
    if (openni::OpenNI::waitForAnyStream(cs, 1, &ci, 0) == openni::STATUS_OK &&
        d.colour.readFrame(&d.colour_frame) == openni::STATUS_OK && d.colour_frame.isValid() &&
        d.colour_frame.getWidth() == config_.width && d.colour_frame.getHeight() == config_.height &&
        d.colour_frame.getVideoMode().getPixelFormat() == openni::PIXEL_FORMAT_RGB888) {
      const uint8_t* c = static_cast<const uint8_t*>(d.colour_frame.getData());
      for (int v = 0; v < config_.height; ++v)
        std::memcpy(static_cast<void*>(frame.colour + std::size_t(v) * std::size_t(config_.width)),
                    c + std::size_t(v) * std::size_t(d.colour_frame.getStrideInBytes()), std::size_t(config_.width) * 3u);
      frame.has_colour = true;
    }
  }
  return HalStatus::kOk;
}

}  // namespace edgefuse::hal
