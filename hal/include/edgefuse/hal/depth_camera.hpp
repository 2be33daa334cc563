// A depth camera (structured light, ToF, stereo): modes, intrinsics, start/stop and frames into
// caller-provided storage. Implementations: sim/, replay/, openni2/, v4l2/, null/.
#pragma once

#include <cstdint>

#include "edgefuse/hal/depth_frame.hpp"
#include "edgefuse/hal/hal_status.hpp"
#include "edgefuse/sensor/pinhole.hpp"

namespace edgefuse::hal {

//! One stream configuration a camera offers.
struct DepthMode {
  int width = 0;              //!< pixels
  int height = 0;             //!< rows
  int fps = 0;                //!< nominal frame rate (0: as fast as possible, e.g. replay)
  float depth_scale = 1000;   //!< raw / depth_scale = metres (1000: 1 mm units, 10000: 100 um)
  bool colour = false;        //!< registered colour delivered with depth
  bool amplitude = false;     //!< ToF amplitude delivered with depth
};

class DepthCamera {
 public:
  virtual ~DepthCamera() = default;

  //! Name for logs and the status command (the board's device name).
  virtual const char* name() const = 0;
  //! Number of modes; they are listed by mode().
  virtual int mode_count() const = 0;
  //! Mode `index` in [0, mode_count()).
  //! \param index mode index  \param mode receives the mode
  virtual bool mode(int index, DepthMode& mode) const = 0;
  //! Opens the device (if needed) and starts streaming in mode `index`. Calling start() after
  //! stop() reopens the device: the acquisition runtime uses this to recover a stalled camera.
  //! \param mode_index index into the mode list
  virtual HalStatus start(int mode_index) = 0;
  //! Stops streaming and releases the device. Safe to call in any state.
  virtual void stop() = 0;
  //! Intrinsics of the running mode (depth and registered colour share them).
  virtual PinholeIntrinsics intrinsics() const = 0;
  //! Waits up to timeout_ms for the next frame and writes it into `frame`'s storage, with its
  //! capture stamp (HAL clock, monotonic) and the device's sequence number.
  //! \param frame caller-provided storage, must fit the mode (else kInvalidArgument)
  //! \param timeout_ms longest wait
  virtual HalStatus next_frame(DepthFrame& frame, uint32_t timeout_ms) = 0;
};

}  // namespace edgefuse::hal
