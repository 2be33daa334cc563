// Where the programs find the boards' data (one folder per board: board.toml, hal.toml, ...).
//
// Resolved at run time, never baked in: one build serves both the build tree (tools/run, ctest)
// and the Debian package (cpack installs the very binaries of the build tree), so a path compiled
// into the binary would either point into the source tree on the robot or be wrong in the build
// tree. The search, first match wins:
//   1. the folder given by set_board_data_dir() (edgefused --board-dir, edgefuse acquire --board-dir)
//   2. <folder of the executable>/../share/edgefuse/board  (the installed layout, /usr/share/...)
//   3. the folder named in the build tree's marker file kBoardDirMarker, looked for in the
//      executable's folder and up to three folders above it; CMake writes it into the build
//      directory and no install rule copies it, so installed binaries never see a source path.
#pragma once

#include <string>

namespace edgefuse::hal {

//! File name of the build tree's marker (its one line: the source tree's board/ folder).
inline constexpr const char* kBoardDirMarker = "edgefuse-board-dir.txt";

//! Uses `dir` instead of the search (an explicit option); "" restores the search.
void set_board_data_dir(const std::string& dir);

//! The folder holding board/<name>/ folders. \return false with `err` listing every place searched
bool board_data_dir(std::string& dir, std::string& err);

//! <board data folder>/<board>/<file>. \return false with `err` as board_data_dir(), or naming the
//! board's missing folder and the data folder it was looked for in
bool board_file_path(const std::string& board, const char* file, std::string& path, std::string& err);

}  // namespace edgefuse::hal
