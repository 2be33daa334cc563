// The runtime configuration file (TOML, read with toml++ at start-up) and `--set key=value`
// overrides, both into the parameter table (edgefuse/runtime/params.hpp), which range-checks every
// value. Errors name the file, the key, the value and the allowed range.
#pragma once

#include <string>

#include "edgefuse/runtime/params.hpp"

namespace edgefuse::hal {

//! Reads a TOML file; every key must be a known parameter ("[link] tcp_port = 5555" is
//! link.tcp_port).
//! \param path   the file
//! \param params values are stored here
//! \param err    on failure: "PATH: link.tcp_port = 70000 is out of range [0, 65535]"
bool load_config_toml(const std::string& path, runtime::ParamStore& params, std::string& err);

//! Applies one "key=value" override.
//! \param kv     the text after --set
//! \param params values are stored here
//! \param err    on failure: "--set KEY=VALUE: ..."
bool apply_override(const std::string& kv, runtime::ParamStore& params, std::string& err);

}  // namespace edgefuse::hal
