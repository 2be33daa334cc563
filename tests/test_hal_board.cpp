// board/<name>/hal.toml: every board's file reads and is consistent; broken files are refused
// with a message naming the file, the table and the key.
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <string>

#include "edgefuse/board_config.hpp"
#include "edgefuse/io/board_hal.hpp"
#include "test_support.hpp"

using namespace edgefuse;

namespace {
std::string board_file(const char* board) { return std::string(EDGEFUSE_TEST_BOARD_DIR) + "/" + board + "/hal.toml"; }

std::string write_tmp(const std::string& text) {
  const std::string p = "/tmp/edgefuse_test_hal_" + std::to_string(::getpid()) + ".toml";
  std::ofstream(p) << text;
  return p;
}

std::string error_of(const std::string& text) {
  io::BoardHal hal;
  std::string err;
  const std::string p = write_tmp(text);
  CHECK_FALSE(io::read_board_hal(p, hal, err));
  std::remove(p.c_str());
  return err;
}
}  // namespace

TEST_GROUP(HalBoard){};

TEST(HalBoard, EveryBoardFileReads) {
  for (const char* b : {"host-sim", "rpi4", "am335x"}) {
    io::BoardHal hal;
    std::string err;
    CHECK_TEXT(io::read_board_hal(board_file(b), hal, err), err.c_str());
    CHECK(!hal.cameras.empty());
  }
  io::BoardHal rpi;
  std::string err;
  CHECK(io::read_board_hal(board_file("rpi4"), rpi, err));
  CHECK(rpi.cameras[0].backend == io::CameraBackend::kOpenni2);
  CHECK_EQUAL(0x1d27, rpi.cameras[0].usb_vid);
  CHECK(rpi.cameras[1].backend == io::CameraBackend::kV4l2);
  STRCMP_EQUAL("/dev/video0", rpi.cameras[1].uri.c_str());
  DOUBLES_EQUAL(0.0002, rpi.cameras[1].depth_unit_m, 1e-12);
  CHECK(rpi.cameras[1].has_intrinsics);
  DOUBLES_EQUAL(88.95, rpi.cameras[1].fy, 1e-9);
  const io::BoardPin* pin = rpi.find_pin(rpi.scanners[0].trigger_pin);
  CHECK(pin != nullptr);
  STRCMP_EQUAL("gpiochip0", pin->chip.c_str());
  CHECK_EQUAL(17, pin->offset);
  CHECK_EQUAL(50, pin->debounce_us);
}

TEST(HalBoard, BadFilesAreRefusedWithTheirReason) {
  STRCMP_CONTAINS("backend = 'kinect' is not one of sim, replay, openni2, v4l2, null",
                  error_of("[[camera]]\nname = \"x\"\nbackend = \"kinect\"\n").c_str());
  STRCMP_CONTAINS("usb_vid", error_of("[[camera]]\nname = \"x\"\nbackend = \"sim\"\nusb_vid = 70000\nusb_pid = 1\n").c_str());
  STRCMP_CONTAINS("usb_vid and usb_pid go together",
                  error_of("[[camera]]\nname = \"x\"\nbackend = \"sim\"\nusb_vid = 1\n").c_str());
  STRCMP_CONTAINS("v4l2 needs uri", error_of("[[camera]]\nname = \"x\"\nbackend = \"v4l2\"\n").c_str());
  STRCMP_CONTAINS("v4l2 needs width, height, fx",
                  error_of("[[camera]]\nname = \"x\"\nbackend = \"v4l2\"\nuri = \"/dev/video0\"\n").c_str());
  STRCMP_CONTAINS("trigger_pin 'p' is not a [[pin]]",
                  error_of("[[line_scanner]]\nname = \"l\"\nbackend = \"sim\"\ntrigger_pin = \"p\"\n").c_str());
  STRCMP_CONTAINS("is not an input",
                  error_of("[[pin]]\nname = \"p\"\nchip = \"gpiochip0\"\noffset = 3\ndirection = \"output\"\n"
                           "[[line_scanner]]\nname = \"l\"\nbackend = \"sim\"\ntrigger_pin = \"p\"\n")
                      .c_str());
  STRCMP_CONTAINS("[[pin]] #1 (line 1)", error_of("[[pin]]\nname = \"p\"\nchip = \"c\"\noffset = -1\ndirection = \"input\"\n").c_str());
  STRCMP_CONTAINS("camera name 'x' is used twice",
                  error_of("[[camera]]\nname = \"x\"\nbackend = \"sim\"\n[[camera]]\nname = \"x\"\nbackend = \"sim\"\n").c_str());
  STRCMP_CONTAINS("TOML syntax error", error_of("[[camera]\n").c_str());
}
