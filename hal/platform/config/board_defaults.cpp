#include "edgefuse/hal/platform/config/board_defaults.hpp"

#include <toml++/toml.h>

#include <fstream>
#include <sstream>

#include "edgefuse/hal/platform/config/board_data_dir.hpp"
#include "edgefuse/memory/arena.hpp"
#include "edgefuse/tsdf/volume.hpp"
#include "edgefuse/hal/platform/config/toml_guard.hpp"

namespace edgefuse::hal {
namespace {

template <class T>
bool read_number(const toml::table& t, const std::string& file, const char* key, T lo, T hi, T& out,
                 std::string& err) {
  const auto node = t["tsdf"][key];
  if (!node) return true;  // keep the built-in default
  const std::optional<double> v = node.value<double>();
  if (!v || *v < double(lo) || *v > double(hi)) {
    err = file + ": tsdf." + key + " must be a number in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
    return false;
  }
  out = T(*v);
  return true;
}

// [tsdf] dim, when given, must be a space the board's index holds; without it the default space
// is the whole index.
bool resolve_dim(const std::string& board, const std::string& file, int& dim, std::string& err) {
  const BoardCapacities* caps = find_board(board.c_str());
  if (dim == 0) {
    dim = caps != nullptr ? caps->volume_dim : 0;
    return true;
  }
  return check_space_dim(board, dim, file + ": tsdf.dim", err);
}

}  // namespace

bool check_space_dim(const std::string& board, int dim, const std::string& what, std::string& err) {
  const BoardCapacities* caps = find_board(board.c_str());
  if (caps == nullptr || (dim % kBrickSide == 0 && dim <= caps->volume_dim)) return true;
  err = what + " = " + std::to_string(dim) + ": the space must be a multiple of " + std::to_string(kBrickSide) +
        " voxels per axis up to board " + board + "'s capacity.volume_dim (" + std::to_string(caps->volume_dim) + ")";
  return false;
}

bool read_board_defaults(const std::string& board, BoardDefaults& out, std::string& err) {
  std::string file;
  if (!board_file_path(board, "board.toml", file, err)) return false;
  std::ifstream in(file, std::ios::binary);
  if (!in) {
    err = file + ": cannot open the board file";
    return false;
  }
  std::stringstream text;
  text << in.rdbuf();
  if (const unsigned line = io::toml_non_ascii_line(text.str())) {  // toml++ 3.3.0's undefined behaviour
    err = file + ":" + std::to_string(line) + ": " + io::toml_non_ascii_reason();
    return false;
  }
  toml::table t;
  try {
    t = toml::parse(text.str(), file);
  } catch (const toml::parse_error& e) {
    err = file + ": " + std::string(e.description());
    return false;
  }
  out.name = board;
  return read_number(t, file, "dim", 8, 4096, out.dim, err) && resolve_dim(board, file, out.dim, err) &&
         read_number(t, file, "voxel_m", 1e-4f, 1.0f, out.voxel_m, err) &&
         read_number(t, file, "trunc_m", 1e-4f, 10.0f, out.trunc_m, err) &&
         read_number(t, file, "max_weight", 1, 255, out.max_weight, err) &&
         read_number(t, file, "threads", 1, 64, out.threads, err);
}

}  // namespace edgefuse::hal
