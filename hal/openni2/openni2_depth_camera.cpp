#include "hal/openni2/openni2_depth_camera.hpp"

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
  if (!found) {
    int n = std::snprintf(error_, sizeof(error_), "openni2 '%s': no depth mode %dx%d@%d %s; offered:", config_.uri,
                          config_.width, config_.height, config_.fps,
                          config_.format == Openni2DepthFormat::k100um ? "100um" : "1mm");
    for (int i = 0; i < modes.getSize() && n > 0 && std::size_t(n) < sizeof(error_); ++i)
      n += std::snprintf(error_ + n, sizeof(error_) - std::size_t(n), " %dx%d@%d/fmt%d", modes[i].getResolutionX(),
                         modes[i].getResolutionY(), modes[i].getFps(), int(modes[i].getPixelFormat()));
    return fail(HalStatus::kInvalidArgument, "mode");
  }
  // Colour registered to depth: only when the device can register (else colour is not delivered,
  // since unregistered colour would paint the wrong voxels).
  colour_registered_ = false;
  if (config_.colour && d.device.hasSensor(openni::SENSOR_COLOR) &&
      d.device.isImageRegistrationModeSupported(openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR)) {
    if (d.colour.create(d.device, openni::SENSOR_COLOR) == openni::STATUS_OK &&
        d.device.setImageRegistrationMode(openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR) == openni::STATUS_OK) {
      d.device.setDepthColorSyncEnabled(true);
      d.has_colour = d.colour.start() == openni::STATUS_OK;
      colour_registered_ = d.has_colour;
    }
  }
  // Intrinsics: the board's, else from the reported field of view (centred principal point).
  intr_ = config_.intr;
  intr_.width = config_.width;
  intr_.height = config_.height;
  intr_.depth_scale = config_.format == Openni2DepthFormat::k100um ? 10000.0f : 1000.0f;
  if (!(intr_.fx > 0)) {
    float hfov = d.depth.getHorizontalFieldOfView(), vfov = d.depth.getVerticalFieldOfView();
    if (!(hfov > 0.1f) || !(vfov > 0.1f)) {  // not reported (Dummy, some recordings): Xtion's 58 x 45 deg
      hfov = 58.0f * 3.14159265f / 180.0f;
      vfov = 45.0f * 3.14159265f / 180.0f;
    }
    intr_.fx = 0.5f * float(config_.width) / std::tan(0.5f * hfov);
    intr_.fy = 0.5f * float(config_.height) / std::tan(0.5f * vfov);
    intr_.cx = 0.5f * float(config_.width) - 0.5f;
    intr_.cy = 0.5f * float(config_.height) - 0.5f;
  }
  if (d.depth.start() != openni::STATUS_OK) return fail(HalStatus::kIoError, "start depth stream");
  running_ = true;
  have_offset_ = false;
  return HalStatus::kOk;
}

void Openni2DepthCamera::stop() {
  if (!impl_ || !impl_->initialised) return;
  Impl& d = *impl_;
  const bool was_streaming = d.depth.isValid();
  d.depth_frame.release();
  d.colour_frame.release();
  if (d.has_colour) d.colour.stop();
  if (d.depth.isValid()) d.depth.stop();
  // OpenNI2's Dummy driver does not join its frame thread on stop(): destroying the stream while
  // that thread sleeps its 33 ms frame period crashes. Two periods are enough (and harmless for
  // real devices, whose stop() joins).
  if (was_streaming) std::this_thread::sleep_for(std::chrono::milliseconds(100));
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
  // Device microseconds -> HAL clock.
  const uint64_t now = clock_.now_us();
  const int64_t dev = int64_t(f.getTimestamp());
  if (!have_offset_ || std::llabs(int64_t(now) - (dev + offset_us_)) > 100000) {
    offset_us_ = int64_t(now) - dev;
    have_offset_ = true;
  }
  uint64_t stamp = uint64_t(dev + offset_us_);
  if (stamp <= last_stamp_us_) stamp = last_stamp_us_ + 1;
  frame.stamp_us = stamp;
  last_stamp_us_ = stamp;
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
