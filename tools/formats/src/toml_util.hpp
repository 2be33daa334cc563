// toml++ (header-only) behind small checked getters whose messages name file, context and key.
#pragma once

// toml++ 3.3 assert()s on some malformed input (e.g. "[[{x]]") that its NDEBUG build reports as a
// parse error: give every build type the NDEBUG behaviour so corrupt files never abort. (With
// clang + NDEBUG that assertion becomes __builtin_assume; the project builds with GCC.)
#ifndef NDEBUG
#define TOML_ASSERT(expr) static_assert(true)
#endif
#include <toml++/toml.h>

#include <string>
#include <vector>

#include "edgefuse/sensor/pinhole.hpp"

namespace edgefuse::io::detail {

//! Reads and parses a TOML file; syntax errors become "<path>:<line>:<col>: TOML syntax error: ...".
bool parse_toml_file(const std::string& path, toml::table& out, std::string& err);

//! Checked access to the keys of one table. `where` prefixes every message, e.g.
//! "/x/rig.toml: sensor 'xtion' (line 4)". Getters return false and set the error.
class TomlFields {
 public:
  TomlFields(const toml::table& t, std::string where, std::string& err) : t_(t), where_(std::move(where)), err_(err) {}

  bool has(const char* key) const { return t_.contains(key); }
  //! An integer in [lo, hi]. Absent: error when required, else `v` is left unchanged.
  bool get_int(const char* key, long long& v, bool required, long long lo, long long hi);
  //! A finite number (integer or float); `positive` demands > 0, `non_negative` >= 0.
  bool get_number(const char* key, double& v, bool required, bool positive = false, bool non_negative = false);
  bool get_bool(const char* key, bool& v, bool required);
  bool get_string(const char* key, std::string& v, bool required);
  //! An array of finite numbers.
  bool get_number_array(const char* key, std::vector<double>& v, bool required);

  bool fail(const std::string& what);  //!< sets "<where>: <what>", returns false
  const std::string& where() const { return where_; }

 private:
  std::string describe(const char* key) const;
  const toml::table& t_;
  std::string where_;
  std::string& err_;
};

//! The array of tables `key` ([[key]]) of `t`: null when absent; an error naming `path` when
//! `key` is something else.
//! \param path file (for the message)  \param t parent table  \param key array name
//! \param arr out: the array or null  \param err out: the message  \return false on error
bool table_array(const std::string& path, const toml::table& t, const char* key, const toml::array*& arr,
                 std::string& err);

//! Where one table of an array of tables is: "<path>: [[<kind>]] #<index + 1> (line <n>)".
//! \param path file  \param kind array name  \param index 0-based position  \param t the table
std::string table_where(const std::string& path, const char* kind, std::size_t index, const toml::table& t);

//! The pinhole keys shared by camera.toml and rig.toml sensors (width height fx fy cx cy
//! depth_scale [min_range max_range]), range-checked. Ranges required when `ranges_required`.
bool read_pinhole_fields(TomlFields& f, PinholeIntrinsics& intr, bool ranges_required, bool& has_min,
                         bool& has_max);

}  // namespace edgefuse::io::detail
