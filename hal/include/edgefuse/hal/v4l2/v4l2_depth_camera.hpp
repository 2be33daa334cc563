// V4L2 depth camera (UVC depth / ToF cameras): Z16 or Y16 frames, mmap streaming with a fixed
// buffer count, poll with timeout, format negotiation (the driver's adjusted format must match the
// mode exactly, else start() fails naming what the driver offered). The depth unit comes from the
// board config (V4L2 does not report it); intrinsics too. Buffer stamps are CLOCK_MONOTONIC (the
// HAL clock). Every system call goes through V4l2Sys.
#pragma once

#include <cstdint>

#include "edgefuse/hal/depth_camera.hpp"
#include "edgefuse/hal/v4l2/v4l2_sys.hpp"

namespace edgefuse::hal {

struct V4l2CameraConfig {
  const char* name = "tof";            //!< board device name
  const char* device = "/dev/video0";  //!< device node
  PinholeIntrinsics intr;              //!< size, intrinsics and ranges of the mode (board config)
  float depth_unit_m = 0.001f;         //!< metres per raw unit (board config); depth_scale = 1 / unit
  int fps = 30;                        //!< requested frame rate (VIDIOC_S_PARM; drivers may ignore it)
};

class V4l2DepthCamera final : public DepthCamera {
 public:
  static constexpr int kBuffers = 4;  //!< mmap buffers requested (the driver may grant fewer, >= 2)

  //! \param config device and mode  \param sys kernel boundary (linux_v4l2_sys() or a fake)
  V4l2DepthCamera(const V4l2CameraConfig& config, V4l2Sys& sys) : config_(config), sys_(sys) {}
  ~V4l2DepthCamera() override { stop(); }

  const char* name() const override { return config_.name; }
  int mode_count() const override { return 1; }
  bool mode(int index, DepthMode& mode) const override;
  HalStatus start(int mode_index) override;
  void stop() override;
  PinholeIntrinsics intrinsics() const override;
  HalStatus next_frame(DepthFrame& frame, uint32_t timeout_ms) override;

  //! What went wrong in the last failed call (names the device and the ioctl).
  const char* last_error() const { return error_; }
  //! The negotiated pixel format (V4L2 fourcc), 0 when not streaming.
  uint32_t pixel_format() const { return pixfmt_; }
  int buffer_count() const { return buffer_count_; }

 private:
  HalStatus fail(HalStatus s, const char* what, int err);
  HalStatus negotiate();
  HalStatus map_buffers();
  int xioctl(unsigned long request, void* arg);  // retried on EINTR

  V4l2CameraConfig config_;
  V4l2Sys& sys_;
  int fd_ = -1;
  bool streaming_ = false;
  uint32_t pixfmt_ = 0;
  uint32_t bytes_per_line_ = 0;
  void* buffers_[kBuffers] = {};
  std::size_t lengths_[kBuffers] = {};
  int buffer_count_ = 0;
  char error_[160] = {};
};

}  // namespace edgefuse::hal
