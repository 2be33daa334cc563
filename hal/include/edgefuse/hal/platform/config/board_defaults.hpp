// Run-time defaults of a board (board/<name>/board.toml, section [tsdf]).
#pragma once

#include <string>

namespace edgefuse::hal {

struct BoardDefaults {
  std::string name;
  int dim = 0;  //!< voxels per axis of the default space ([tsdf] dim, else the board's capacity.volume_dim)
  float voxel_m = 0.004f;
  float trunc_m = 0.016f;
  int max_weight = 255;
  int threads = 1;
};

//! Reads <board data folder>/<name>/board.toml (the folder: board_data_dir.hpp).
//! \return false with `err` naming the file and key when a value is missing or out of range
bool read_board_defaults(const std::string& board, BoardDefaults& out, std::string& err);

//! Whether board `board`'s brick index holds a space of `dim` voxels per axis: a multiple of 8 up
//! to its capacity.volume_dim (an unknown board holds any).
//! \param what names the value in `err` ("tsdf.dim", or the board file's)  \param err why not
bool check_space_dim(const std::string& board, int dim, const std::string& what, std::string& err);

}  // namespace edgefuse::hal
