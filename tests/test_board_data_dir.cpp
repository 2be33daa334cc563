// Where the programs find the board data (board_data_dir.hpp): a build-tree program finds the
// source tree's board/ through the build directory's marker; --board-dir wins; a missing folder
// or board is refused naming what was looked for.
#include <sys/stat.h>
#include <unistd.h>

#include <string>

#include "edgefuse/hal/platform/config/board_data_dir.hpp"
#include "edgefuse/hal/platform/config/board_defaults.hpp"

#include <CppUTest/TestHarness.h>

using namespace edgefuse;

namespace {

// The same folder named two ways (the marker may name it through symlinks).
bool same_folder(const std::string& a, const std::string& b) {
  struct stat sa, sb;
  return ::stat(a.c_str(), &sa) == 0 && ::stat(b.c_str(), &sb) == 0 && sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
}

}  // namespace

TEST_GROUP(BoardDataDir) {
  void teardown() override { hal::set_board_data_dir(""); }
};

TEST(BoardDataDir, BuildTreeFindsTheSourceBoardsThroughTheMarker) {
  std::string dir, err;
  CHECK_TRUE_TEXT(hal::board_data_dir(dir, err), err.c_str());
  CHECK_TRUE_TEXT(same_folder(dir, EDGEFUSE_TEST_BOARD_DIR), dir.c_str());
  std::string path;
  CHECK_TRUE_TEXT(hal::board_file_path("rpi4", "hal.toml", path, err), err.c_str());
  STRCMP_EQUAL((dir + "/rpi4/hal.toml").c_str(), path.c_str());
  hal::BoardDefaults d;
  CHECK_TRUE_TEXT(hal::read_board_defaults("am335x", d, err), err.c_str());
  DOUBLES_EQUAL(0.004, d.voxel_m, 1e-9);
}

TEST(BoardDataDir, OptionWins) {
  const std::string tmp = "/tmp/edgefuse_test_board_dir_" + std::to_string(::getpid());
  ::mkdir(tmp.c_str(), 0755);
  ::mkdir((tmp + "/myboard").c_str(), 0755);
  hal::set_board_data_dir(tmp);
  std::string dir, err, path;
  CHECK_TRUE_TEXT(hal::board_data_dir(dir, err), err.c_str());
  STRCMP_EQUAL(tmp.c_str(), dir.c_str());
  CHECK_TRUE_TEXT(hal::board_file_path("myboard", "board.toml", path, err), err.c_str());
  STRCMP_EQUAL((tmp + "/myboard/board.toml").c_str(), path.c_str());
  // A board without a folder there: named with the folder it was looked for in.
  CHECK_FALSE(hal::board_file_path("rpi4", "hal.toml", path, err));
  STRCMP_EQUAL(("board 'rpi4': no folder " + tmp + "/rpi4").c_str(), err.c_str());
  ::rmdir((tmp + "/myboard").c_str());
  ::rmdir(tmp.c_str());
}

TEST(BoardDataDir, MissingOptionFolderIsNamed) {
  hal::set_board_data_dir("/nonexistent/edgefuse-boards");
  std::string dir, err;
  CHECK_FALSE(hal::board_data_dir(dir, err));
  STRCMP_EQUAL("board data folder /nonexistent/edgefuse-boards (--board-dir) does not exist", err.c_str());
  hal::BoardDefaults d;
  CHECK_FALSE(hal::read_board_defaults("rpi4", d, err));
  STRCMP_CONTAINS("/nonexistent/edgefuse-boards", err.c_str());
}
