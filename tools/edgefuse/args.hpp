// Command-line options of the edgefuse subcommands: positionals and "--name value" pairs, with
// typed getters that range-check and name the option in their error message.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "edgefuse/math/pose.hpp"

namespace edgefuse::cli {

class Args {
 public:
  //! Splits argv (after the subcommand). `flags` are options without a value.
  //! \return false with `err` set on a malformed line (missing value, unknown option)
  bool parse(int argc, char** argv, const std::vector<std::string>& options, const std::vector<std::string>& flags,
             std::string& err);
  const std::vector<std::string>& positional() const { return positional_; }
  bool has(const std::string& name) const { return values_.count(name) != 0; }
  std::string get(const std::string& name, const std::string& fallback = "") const;
  //! Integer option within [lo, hi].
  bool get_int(const std::string& name, int lo, int hi, int& out, std::string& err) const;
  //! Number option within [lo, hi].
  bool get_float(const std::string& name, float lo, float hi, float& out, std::string& err) const;
  //! "x,y,z" option.
  bool get_vec3(const std::string& name, Vec3f& out, std::string& err) const;

 private:
  std::vector<std::string> positional_;
  std::map<std::string, std::string> values_;
};

}  // namespace edgefuse::cli
