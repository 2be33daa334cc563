// Helpers shared by the suites. Include STL / Eigen / edgefuse headers before this file's
// CppUTest include (its `new` macro breaks placement new).
#pragma once

#include <cstdio>
#include <cstdlib>
#include <string>

#include <CppUTest/TestHarness.h>

namespace edgefuse_test {

//! ../shared/data (or $EDGEFUSE_SHARED_DATA); empty when absent.
inline std::string shared_data_dir() {
  const char* env = std::getenv("EDGEFUSE_SHARED_DATA");
  std::string dir = env && *env ? env : EDGEFUSE_SHARED_DATA;
  std::FILE* f = std::fopen((dir + "/README.md").c_str(), "r");
  if (!f) return std::string();
  std::fclose(f);
  return dir;
}

//! Path of a data set folder, or empty after printing why the test is skipped.
inline std::string require_data(const char* name) {
  const std::string root = shared_data_dir();
  if (root.empty()) {
    std::printf("\n  SKIP: shared test data not found (set EDGEFUSE_SHARED_DATA or place ../shared/data)\n");
    return std::string();
  }
  return root + "/" + name;
}

}  // namespace edgefuse_test
