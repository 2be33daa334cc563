#include "args.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>

namespace edgefuse::cli {

bool Args::parse(int argc, char** argv, const std::vector<std::string>& options,
                 const std::vector<std::string>& flags, std::string& err) {
  for (int i = 0; i < argc; ++i) {
    const std::string a = argv[i];
    if (a.rfind("--", 0) != 0 || a == "--") {
      positional_.push_back(a);
      continue;
    }
    const std::string name = a.substr(2);
    if (std::find(flags.begin(), flags.end(), name) != flags.end()) {
      values_[name] = "1";
      continue;
    }
    if (std::find(options.begin(), options.end(), name) == options.end()) {
      err = "unknown option " + a;
      return false;
    }
    if (i + 1 >= argc) {
      err = "option " + a + " needs a value";
      return false;
    }
    values_[name] = argv[++i];
  }
  return true;
}

std::string Args::get(const std::string& name, const std::string& fallback) const {
  const auto it = values_.find(name);
  return it == values_.end() ? fallback : it->second;
}

bool Args::get_int(const std::string& name, int lo, int hi, int& out, std::string& err) const {
  if (!has(name)) return true;
  const std::string s = get(name);
  char* end = nullptr;
  errno = 0;
  const long v = std::strtol(s.c_str(), &end, 10);
  if (s.empty() || *end != '\0' || errno != 0 || v < lo || v > hi) {
    err = "--" + name + " must be an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got '" +
          s + "'";
    return false;
  }
  out = int(v);
  return true;
}

bool Args::get_float(const std::string& name, float lo, float hi, float& out, std::string& err) const {
  if (!has(name)) return true;
  const std::string s = get(name);
  char* end = nullptr;
  const float v = std::strtof(s.c_str(), &end);
  if (s.empty() || *end != '\0' || !std::isfinite(v) || v < lo || v > hi) {
    err = "--" + name + " must be a number in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got '" + s +
          "'";
    return false;
  }
  out = v;
  return true;
}

bool Args::get_vec3(const std::string& name, Vec3f& out, std::string& err) const {
  if (!has(name)) return true;
  const std::string s = get(name);
  float v[3];
  const char* p = s.c_str();
  for (int i = 0; i < 3; ++i) {
    char* end = nullptr;
    v[i] = std::strtof(p, &end);
    const bool last = i == 2;
    if (end == p || !std::isfinite(v[i]) || (last ? *end != '\0' : *end != ',')) {
      err = "--" + name + " must be three numbers x,y,z (metres), got '" + s + "'";
      return false;
    }
    p = end + 1;
  }
  out = Vec3f(v[0], v[1], v[2]);
  return true;
}

}  // namespace edgefuse::cli
