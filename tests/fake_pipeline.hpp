// A pipeline stand-in for the runtime's tests (test_runtime_states, test_robot_session): mapping
// counts a frame per step, a localisation finishes 50 ms after it started (on the step clock) with
// the objects fill_result() gives, one device "xtion", no models. Include before CppUTest.
#pragma once

#include <cstdint>

#include "edgefuse/runtime/pipeline.hpp"

namespace edgefuse_test {

class FakePipeline : public edgefuse::runtime::Pipeline {
 public:
  bool mapping = false;
  bool localizing = false;
  uint64_t now = 0;      //!< the last step's time (us)
  uint64_t done_at = 0;  //!< when the running localisation finishes (us)
  uint32_t frames = 0;   //!< frames mapped since the map was reset

  bool start_mapping(const char**) override { return mapping = true; }
  void stop_mapping() override { mapping = false; }
  void reset_map() override { frames = 0; }
  void step(uint64_t t) override {
    now = t;
    if (mapping) ++frames;
  }
  bool start_localization(uint64_t t, const char**) override {
    localizing = true;
    done_at = t + 50000;
    return true;
  }
  bool poll_localization(edgefuse::runtime::LocalizationOutcome& out) override {
    if (!localizing || now < done_at) return false;
    localizing = false;
    fill_result(out);
    return true;
  }
  bool map_empty() const override { return frames == 0; }
  int device_count() const override { return 1; }
  const char* device_name(int) const override { return "xtion"; }
  const char* device_state(int) const override { return "ok"; }
  int model_count() const override { return 0; }
  const char* model_name(int) const override { return ""; }

 protected:
  //! The finished localisation's outcome. \param out receives it
  virtual void fill_result(edgefuse::runtime::LocalizationOutcome& out) = 0;
};

}  // namespace edgefuse_test
