// edgefuse_config_reference: prints docs/CONFIG.md, the reference of edgefused's runtime
// configuration, from the parameter table (kParamDefs, src/runtime/params.cpp). ctest's
// test_docs_config_reference fails when the committed file differs from this output.
#include <cstdio>
#include <cstring>
#include <string>

#include "edgefuse/runtime/params.hpp"

namespace {

using edgefuse::runtime::kParamCount;
using edgefuse::runtime::kParamDefs;
using edgefuse::runtime::ParamStore;
using edgefuse::runtime::ParamType;

const char* type_name(ParamType t) {
  switch (t) {
    case ParamType::kInt: return "integer";
    case ParamType::kFloat: return "number";
    case ParamType::kBool: return "boolean";
    case ParamType::kString: return "text";
  }
  return "?";
}

// A table cell: '|' escaped, the default of a text parameter quoted as in TOML.
std::string cell(const std::string& s) {
  std::string out;
  for (char c : s) out += c == '|' ? std::string("\\|") : std::string(1, c);
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  const bool help = argc == 2 && (!std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h"));
  if (argc > 1) {
    std::fprintf(help ? stdout : stderr,
                 "usage: edgefuse_config_reference > docs/CONFIG.md\n"
                 "  Prints the configuration reference (Markdown) from edgefused's parameter table.\n");
    return help ? 0 : 2;
  }
  const ParamStore defaults;
  std::printf(
      "# Configuration reference\n"
      "\n"
      "<!-- Generated from the parameter table kParamDefs (src/runtime/params.cpp); do not edit.\n"
      "     Regenerate: cmake --build build/host --target edgefuse_config_reference &&\n"
      "     build/host/tools/edgefuse_config_reference > docs/CONFIG.md -->\n"
      "\n"
      "Every runtime parameter of `edgefused`. The same table serves the TOML file (`--config FILE`),\n"
      "the command line (`--set KEY=VALUE`, repeatable) and the serial console (`param get [KEY]`,\n"
      "`param set KEY VALUE`). Every key is optional; a value outside its range stops start-up with the\n"
      "file, line, key and allowed range, e.g.\n"
      "`edgefused: cfg.toml (line 2): localize.min_score = 3 is out of range [0, 1]`.\n"
      "`edgefused --check --config FILE` checks a file without opening devices or ports.\n"
      "\n"
      "Precedence, later wins: the table's default, the board's `board/<name>/board.toml` `[tsdf]`\n"
      "(`voxel_m`, `trunc_m`), the `--config` file, each `--set`. A key `section.name` is written in\n"
      "TOML as `name = value` under `[section]`; text values in quotes. *Live* parameters may be changed\n"
      "with `param set` while edgefused runs; the others only at start-up (the console refuses them with\n"
      "`ERR 5`). An annotated example with every key: `board/host-sim/edgefused.toml`.\n"
      "\n"
      "| key | type | default | range | live | meaning |\n"
      "|---|---|---|---|---|---|\n");
  for (int i = 0; i < kParamCount; ++i) {
    const auto& d = kParamDefs[i];
    char value[ParamStore::kTextCap], range[64];
    defaults.format(i, value, sizeof(value));
    ParamStore::format_range(i, range, sizeof(range));
    std::string shown = d.type == ParamType::kString ? "\"" + std::string(value) + "\"" : value;
    // edgefused sets these two from the board's board.toml [tsdf] before the config file is read
    // (load_parameters in src/firmware/edgefused.cpp); the table's value is only the fallback.
    const bool from_board = !std::strcmp(d.key, "tsdf.dim") || !std::strcmp(d.key, "tsdf.voxel_m") ||
                            !std::strcmp(d.key, "tsdf.trunc_m");
    std::printf("| `%s` | %s | `%s`%s | %s | %s | %s |\n", d.key, type_name(d.type), cell(shown).c_str(),
                from_board ? " (the board's `[tsdf]`)" : "", cell(range).c_str(), d.live ? "yes" : "no",
                cell(d.help).c_str());
  }
  return 0;
}
