// board/<name>/hal.toml: the board's devices as data (Zephyr-style): which HAL backend drives each
// depth camera and line scanner, the USB ids that the hot-plug monitor watches, and the GPIO pin
// map (chip, offset, direction, edge, debounce) of trigger lines. Read at start-up (allocates).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace edgefuse::io {

enum class CameraBackend { kSim, kReplay, kOpenni2, kV4l2, kNull };
enum class ScannerBackend { kSim, kReplay, kNull };
enum class PinDirection { kInput, kOutput };
enum class PinEdge { kRising, kFalling, kBoth };

struct BoardCamera {
  std::string name;               //!< device name (rig sensor name: "xtion", "tof")
  CameraBackend backend = CameraBackend::kSim;
  std::string uri;                //!< openni2: URI ("" any, "Dummy", .oni); v4l2: device node; replay: folder
  int width = 0, height = 0, fps = 0;  //!< requested mode (0: the backend's default)
  double depth_unit_m = 0.001;    //!< v4l2: metres per raw unit
  bool has_intrinsics = false;    //!< fx fy cx cy given (required for v4l2: V4L2 reports none)
  double fx = 0, fy = 0, cx = 0, cy = 0;  //!< pixels, at width x height
  bool has_usb = false;           //!< usb_vid/usb_pid given
  uint16_t usb_vid = 0, usb_pid = 0;
};

struct BoardScanner {
  std::string name;               //!< "laser"
  ScannerBackend backend = ScannerBackend::kSim;
  std::string trigger_pin;        //!< a [[pin]] name (input), empty for sim/replay
};

struct BoardPin {
  std::string name;               //!< "laser_trigger"
  std::string chip;               //!< gpiochip name, path, label or number
  int offset = 0;                 //!< line offset on the chip
  PinDirection direction = PinDirection::kInput;
  PinEdge edge = PinEdge::kRising;  //!< inputs
  int debounce_us = 0;            //!< inputs: edges closer than this are bounces
};

struct BoardHal {
  std::vector<BoardCamera> cameras;
  std::vector<BoardScanner> scanners;
  std::vector<BoardPin> pins;
  const BoardPin* find_pin(const std::string& name) const;
};

//! Parses and checks hal.toml: unique names, known backends, VID/PID in 0..0xffff (both or
//! neither), pins with a chip, offset >= 0, a known direction/edge, trigger pins that exist and
//! are inputs. Messages name the file, the table and the key.
bool read_board_hal(const std::string& path, BoardHal& hal, std::string& err);

}  // namespace edgefuse::io
