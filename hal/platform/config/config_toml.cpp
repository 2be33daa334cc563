#include "edgefuse/hal/platform/config/config_toml.hpp"
#include "edgefuse/hal/platform/config/toml_guard.hpp"

// toml++ 3.3 assert()s on some malformed input; as in tools/formats, every build type gets the
// NDEBUG behaviour (a parse error) so a corrupt config never aborts.
#ifndef NDEBUG
#define TOML_ASSERT(expr) static_assert(true)
#endif
#include <toml++/toml.h>

#include <cstdio>
#include <fstream>
#include <sstream>

namespace edgefuse::hal {

using runtime::kParamDefs;
using runtime::ParamStore;
using runtime::ParamType;

namespace {

bool load_table(const toml::table& t, const std::string& prefix, const std::string& path, ParamStore& params,
                std::string& err) {
  for (const auto& [k, node] : t) {
    const std::string key = prefix.empty() ? std::string(k.str()) : prefix + "." + std::string(k.str());
    if (const toml::table* sub = node.as_table()) {
      if (!load_table(*sub, key, path, params, err)) return false;
      continue;
    }
    const int id = ParamStore::find(key.c_str());
    const std::string where = path + " (line " + std::to_string(node.source().begin.line) + ")";
    if (id < 0) {
      err = where + ": unknown key '" + key + "'";
      return false;
    }
    std::string text;
    const bool want_string = kParamDefs[id].type == ParamType::kString;
    if (auto s = node.value<std::string>(); s && node.is_string()) {
      text = *s;
    } else if (node.is_integer()) {
      text = std::to_string(*node.value<int64_t>());
    } else if (node.is_floating_point()) {
      char buf[64];
      std::snprintf(buf, sizeof(buf), "%.17g", *node.value<double>());
      text = buf;
    } else if (node.is_boolean()) {
      text = *node.value<bool>() ? "true" : "false";
    } else {
      err = where + ": " + key + " has an unsupported value type (array, table or date)";
      return false;
    }
    if (want_string != node.is_string()) {
      char range[48];
      ParamStore::format_range(id, range, sizeof(range));
      err = where + ": " + key + " = " + text + " has the wrong type (allowed: " + range + ")";
      return false;
    }
    char e[200];
    if (!params.set(id, text.c_str(), e, sizeof(e))) {
      err = where + ": " + e;
      return false;
    }
  }
  return true;
}

}  // namespace

bool load_config_toml(const std::string& path, ParamStore& params, std::string& err) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    err = path + ": cannot open the configuration file";
    return false;
  }
  std::stringstream text;
  text << in.rdbuf();
  if (const unsigned line = io::toml_non_ascii_line(text.str())) {  // toml++ 3.3.0's undefined behaviour
    err = path + ":" + std::to_string(line) + ": " + io::toml_non_ascii_reason();
    return false;
  }
  toml::table t;
  try {
    t = toml::parse(text.str(), path);
  } catch (const toml::parse_error& e) {
    const auto& b = e.source().begin;
    err = path + ":" + std::to_string(b.line) + ":" + std::to_string(b.column) +
          ": TOML syntax error: " + std::string(e.description());
    return false;
  }
  // All or nothing: a file refused half-way must not leave its first values behind (found by
  // tests/fuzz: a wrong value after link.baud left the new baud rate set).
  ParamStore loaded = params;
  if (!load_table(t, "", path, loaded, err)) return false;
  params = loaded;
  return true;
}

bool apply_override(const std::string& kv, ParamStore& params, std::string& err) {
  const size_t eq = kv.find('=');
  if (eq == std::string::npos || eq == 0) {
    err = "--set " + kv + ": expected KEY=VALUE";
    return false;
  }
  const std::string key = kv.substr(0, eq);
  const std::string value = kv.substr(eq + 1);
  const int id = ParamStore::find(key.c_str());
  if (id < 0) {
    err = "--set " + kv + ": unknown key '" + key + "'";
    return false;
  }
  char e[200];
  if (!params.set(id, value.c_str(), e, sizeof(e))) {
    err = "--set: " + std::string(e);
    return false;
  }
  return true;
}

}  // namespace edgefuse::hal
