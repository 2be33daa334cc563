#include "edgefuse/hal/v4l2/v4l2_depth_camera.hpp"

#include <fcntl.h>
#include <linux/videodev2.h>
#include <sys/mman.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

namespace edgefuse::hal {

namespace {

void fourcc_text(uint32_t f, char out[5]) {
  for (int i = 0; i < 4; ++i) {
    const char c = char((f >> (8 * i)) & 0xff);
    out[i] = (c >= 32 && c < 127) ? c : '?';
  }
  out[4] = 0;
}

}  // namespace

bool V4l2DepthCamera::mode(int index, DepthMode& m) const {
  if (index != 0) return false;
  m.width = config_.intr.width;
  m.height = config_.intr.height;
  m.fps = config_.fps;
  m.depth_scale = 1.0f / config_.depth_unit_m;
  m.colour = false;
  m.amplitude = false;
  return true;
}

PinholeIntrinsics V4l2DepthCamera::intrinsics() const {
  PinholeIntrinsics i = config_.intr;
  i.depth_scale = 1.0f / config_.depth_unit_m;
  return i;
}

HalStatus V4l2DepthCamera::fail(HalStatus s, const char* what, int err) {
  std::snprintf(error_, sizeof(error_), "%s: %s: %s", config_.device, what, err ? std::strerror(err) : "failed");
  stop();
  return s;
}

int V4l2DepthCamera::xioctl(unsigned long request, void* arg) {
  int r;
  do {
    r = sys_.ioctl(fd_, request, arg);
  } while (r == -1 && errno == EINTR);
  return r;
}

HalStatus V4l2DepthCamera::negotiate() {
  // Z16 (depth) preferred, Y16 (16-bit grey that ToF cameras use for depth) accepted.
  bool has_z16 = false, has_y16 = false;
  for (uint32_t i = 0; i < 64; ++i) {
    v4l2_fmtdesc d{};
    d.index = i;
    d.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    if (xioctl(VIDIOC_ENUM_FMT, &d) == -1) break;  // EINVAL: end of the list
    has_z16 = has_z16 || d.pixelformat == V4L2_PIX_FMT_Z16;
    has_y16 = has_y16 || d.pixelformat == V4L2_PIX_FMT_Y16;
  }
  if (!has_z16 && !has_y16) return fail(HalStatus::kInvalidArgument, "offers neither Z16 nor Y16", 0);
  v4l2_format fmt{};
  fmt.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  fmt.fmt.pix.width = uint32_t(config_.intr.width);
  fmt.fmt.pix.height = uint32_t(config_.intr.height);
  fmt.fmt.pix.pixelformat = has_z16 ? V4L2_PIX_FMT_Z16 : V4L2_PIX_FMT_Y16;
  fmt.fmt.pix.field = V4L2_FIELD_NONE;
  if (xioctl(VIDIOC_S_FMT, &fmt) == -1) return fail(errno == ENODEV ? HalStatus::kNoDevice : HalStatus::kIoError, "VIDIOC_S_FMT", errno);
  const v4l2_pix_format& p = fmt.fmt.pix;
  if (p.width != uint32_t(config_.intr.width) || p.height != uint32_t(config_.intr.height) ||
      (p.pixelformat != V4L2_PIX_FMT_Z16 && p.pixelformat != V4L2_PIX_FMT_Y16)) {
    char got[5];
    fourcc_text(p.pixelformat, got);
    std::snprintf(error_, sizeof(error_), "%s: mode %dx%d not supported, driver offers %ux%u %s", config_.device,
                  config_.intr.width, config_.intr.height, p.width, p.height, got);
    char keep[sizeof(error_)];
    std::memcpy(keep, error_, sizeof(keep));
    stop();
    std::memcpy(error_, keep, sizeof(keep));
    return HalStatus::kInvalidArgument;
  }
  pixfmt_ = p.pixelformat;
  bytes_per_line_ = p.bytesperline ? p.bytesperline : p.width * 2;
  if (bytes_per_line_ < p.width * 2) return fail(HalStatus::kInvalidArgument, "bytesperline below width * 2", 0);
  // Frame rate: best effort (many UVC depth cameras have one rate per size).
  v4l2_streamparm parm{};
  parm.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  parm.parm.capture.timeperframe.numerator = 1;
  parm.parm.capture.timeperframe.denominator = uint32_t(config_.fps > 0 ? config_.fps : 30);
  xioctl(VIDIOC_S_PARM, &parm);
  return HalStatus::kOk;
}

HalStatus V4l2DepthCamera::map_buffers() {
  v4l2_requestbuffers req{};
  req.count = kBuffers;
  req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  req.memory = V4L2_MEMORY_MMAP;
  if (xioctl(VIDIOC_REQBUFS, &req) == -1) return fail(HalStatus::kIoError, "VIDIOC_REQBUFS", errno);
  if (req.count < 2 || req.count > uint32_t(kBuffers)) return fail(HalStatus::kIoError, "driver granted too few buffers", 0);
  buffer_count_ = int(req.count);
  for (int i = 0; i < buffer_count_; ++i) {
    v4l2_buffer b{};
    b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    b.memory = V4L2_MEMORY_MMAP;
    b.index = uint32_t(i);
    if (xioctl(VIDIOC_QUERYBUF, &b) == -1) return fail(HalStatus::kIoError, "VIDIOC_QUERYBUF", errno);
    void* m = sys_.mmap(b.length, PROT_READ | PROT_WRITE, MAP_SHARED, fd_, off_t(b.m.offset));
    if (m == MAP_FAILED) return fail(HalStatus::kIoError, "mmap", errno);
    buffers_[i] = m;
    lengths_[i] = b.length;
    if (xioctl(VIDIOC_QBUF, &b) == -1) return fail(HalStatus::kIoError, "VIDIOC_QBUF", errno);
  }
  return HalStatus::kOk;
}

HalStatus V4l2DepthCamera::start(int mode_index) {
  if (mode_index != 0) return HalStatus::kInvalidArgument;
  stop();
  error_[0] = 0;
  if (config_.intr.validate() != Status::kOk || !(config_.depth_unit_m > 0))
    return fail(HalStatus::kInvalidArgument, "invalid board config (intrinsics or depth unit)", 0);
  fd_ = sys_.open(config_.device, O_RDWR | O_NONBLOCK);
  if (fd_ < 0) {
    const int e = errno;
    fd_ = -1;
    return fail(e == ENOENT || e == ENODEV || e == ENXIO ? HalStatus::kNoDevice : HalStatus::kIoError, "open", e);
  }
  v4l2_capability cap{};
  if (xioctl(VIDIOC_QUERYCAP, &cap) == -1) return fail(HalStatus::kIoError, "VIDIOC_QUERYCAP (not a V4L2 device?)", errno);
  const uint32_t caps = (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
  if (!(caps & V4L2_CAP_VIDEO_CAPTURE) || !(caps & V4L2_CAP_STREAMING))
    return fail(HalStatus::kInvalidArgument, "no video capture with streaming", 0);
  HalStatus s = negotiate();
  if (s != HalStatus::kOk) return s;
  s = map_buffers();
  if (s != HalStatus::kOk) return s;
  int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (xioctl(VIDIOC_STREAMON, &type) == -1) return fail(HalStatus::kIoError, "VIDIOC_STREAMON", errno);
  streaming_ = true;
  return HalStatus::kOk;
}

void V4l2DepthCamera::stop() {
  if (fd_ < 0) return;
  if (streaming_) {
    int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    xioctl(VIDIOC_STREAMOFF, &type);
    streaming_ = false;
  }
  for (int i = 0; i < buffer_count_; ++i)
    if (buffers_[i]) sys_.munmap(buffers_[i], lengths_[i]);
  if (buffer_count_ > 0) {
    v4l2_requestbuffers req{};
    req.count = 0;
    req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    req.memory = V4L2_MEMORY_MMAP;
    xioctl(VIDIOC_REQBUFS, &req);
  }
  for (int i = 0; i < kBuffers; ++i) {
    buffers_[i] = nullptr;
    lengths_[i] = 0;
  }
  buffer_count_ = 0;
  sys_.close(fd_);
  fd_ = -1;
  pixfmt_ = 0;
}

HalStatus V4l2DepthCamera::next_frame(DepthFrame& frame, uint32_t timeout_ms) {
  if (!streaming_) return HalStatus::kNotStarted;
  const int w = config_.intr.width, h = config_.intr.height;
  if (!frame.fits(w, h)) return HalStatus::kInvalidArgument;
  pollfd pfd{fd_, POLLIN, 0};
  int r;
  // EINTR: poll again (a signal is not a timeout; the wait restarts, at most one extra timeout).
  do {
    r = sys_.poll(&pfd, 1, int(timeout_ms));
  } while (r == -1 && errno == EINTR);
  if (r == 0) return HalStatus::kTimeout;
  if (r < 0) {
    std::snprintf(error_, sizeof(error_), "%s: poll: %s", config_.device, std::strerror(errno));
    return HalStatus::kIoError;
  }
  // A disconnected UVC device reports POLLERR; DQBUF then fails with ENODEV (or EIO).
  const bool hangup = (pfd.revents & (POLLERR | POLLHUP | POLLNVAL)) != 0;
  v4l2_buffer b{};
  b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  b.memory = V4L2_MEMORY_MMAP;
  if (xioctl(VIDIOC_DQBUF, &b) == -1) {
    const int e = errno;
    if (e == EAGAIN) return HalStatus::kTimeout;
    std::snprintf(error_, sizeof(error_), "%s: VIDIOC_DQBUF: %s", config_.device, std::strerror(e));
    return (e == ENODEV || (e == EIO && hangup)) ? HalStatus::kNoDevice : HalStatus::kIoError;
  }
  if (b.index >= uint32_t(buffer_count_)) return HalStatus::kIoError;
  HalStatus result = HalStatus::kOk;
  if (b.flags & V4L2_BUF_FLAG_ERROR) {
    std::snprintf(error_, sizeof(error_), "%s: buffer %u flagged corrupt by the driver", config_.device, b.index);
    result = HalStatus::kBadFrame;
  } else if (b.bytesused < bytes_per_line_ * uint32_t(h - 1) + uint32_t(w) * 2u) {
    std::snprintf(error_, sizeof(error_), "%s: truncated frame (%u of %u bytes)", config_.device, b.bytesused,
                  bytes_per_line_ * uint32_t(h));
    result = HalStatus::kBadFrame;
  } else {
    const uint8_t* src = static_cast<const uint8_t*>(buffers_[b.index]);
    for (int v = 0; v < h; ++v)
      std::memcpy(frame.depth + std::size_t(v) * std::size_t(w), src + std::size_t(v) * bytes_per_line_,
                  std::size_t(w) * 2u);
    frame.width = w;
    frame.height = h;
    frame.depth_scale = 1.0f / config_.depth_unit_m;
    frame.has_colour = false;
    frame.has_amplitude = false;
    frame.stamp_us = uint64_t(b.timestamp.tv_sec) * 1000000u + uint64_t(b.timestamp.tv_usec);
    frame.sequence = b.sequence;
  }
  // The buffer goes back to the driver whatever its content was.
  if (xioctl(VIDIOC_QBUF, &b) == -1) {
    const int e = errno;
    std::snprintf(error_, sizeof(error_), "%s: VIDIOC_QBUF: %s", config_.device, std::strerror(e));
    return e == ENODEV ? HalStatus::kNoDevice : HalStatus::kIoError;
  }
  return result;
}

}  // namespace edgefuse::hal
