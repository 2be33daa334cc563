#include "edgefuse/hal/platform/config/board_data_dir.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <fstream>

namespace edgefuse::hal {
namespace {

std::string g_override_dir;  // set_board_data_dir(); start-up only

bool is_dir(const std::string& path) {
  struct stat st;
  return ::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

// The running executable's folder ("" when /proc is not mounted). Under qemu-user /proc/self/exe
// names the emulated program, as on the board.
std::string executable_dir() {
  char buf[4096];
  const ssize_t n = ::readlink("/proc/self/exe", buf, sizeof(buf) - 1);
  if (n <= 0) return "";
  const std::string exe(buf, size_t(n));
  const size_t slash = exe.rfind('/');
  return slash == std::string::npos ? "" : exe.substr(0, slash);
}

// The board folder named by the build tree's marker in `dir` ("" when there is none).
std::string read_marker(const std::string& dir) {
  std::ifstream in(dir + "/" + kBoardDirMarker);
  std::string line;
  if (!in || !std::getline(in, line)) return "";
  return line;
}

}  // namespace

void set_board_data_dir(const std::string& dir) { g_override_dir = dir; }

bool board_data_dir(std::string& dir, std::string& err) {
  if (!g_override_dir.empty()) {
    if (is_dir(g_override_dir)) {
      dir = g_override_dir;
      return true;
    }
    err = "board data folder " + g_override_dir + " (--board-dir) does not exist";
    return false;
  }
  const std::string exe_dir = executable_dir();
  std::string searched;
  if (!exe_dir.empty()) {
    const std::string installed = exe_dir + "/../share/edgefuse/board";
    if (is_dir(installed)) {
      dir = installed;
      return true;
    }
    searched = installed;
    std::string up = exe_dir;
    for (int level = 0; level <= 3; ++level, up += "/..") {
      const std::string marked = read_marker(up);
      if (!marked.empty() && is_dir(marked)) {
        dir = marked;
        return true;
      }
      searched += ", " + up + "/" + kBoardDirMarker + (marked.empty() ? "" : " (names " + marked + ")");
    }
  } else {
    searched = "nothing: /proc/self/exe is unreadable";
  }
  err = "no board data folder found; searched " + searched + "; give one with --board-dir";
  return false;
}

bool board_file_path(const std::string& board, const char* file, std::string& path, std::string& err) {
  std::string dir;
  if (!board_data_dir(dir, err)) return false;
  if (!is_dir(dir + "/" + board)) {
    err = "board '" + board + "': no folder " + dir + "/" + board;
    return false;
  }
  path = dir + "/" + board + "/" + file;
  return true;
}

}  // namespace edgefuse::hal
