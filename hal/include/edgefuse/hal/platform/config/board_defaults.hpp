// Run-time defaults of a board (board/<name>/board.toml, section [tsdf]).
#pragma once

#include <string>

namespace edgefuse::hal {

struct BoardDefaults {
  std::string name;
  int dim = 0;  //!< voxels per axis of the space a run uses by default (0: the board's capacity)
  float voxel_m = 0.004f;
  float trunc_m = 0.016f;
  int max_weight = 255;
  int threads = 1;
};

//! Reads <board data folder>/<name>/board.toml (the folder: board_data_dir.hpp).
//! \return false with `err` naming the file and key when a value is missing or out of range
bool read_board_defaults(const std::string& board, BoardDefaults& out, std::string& err);

}  // namespace edgefuse::hal
