// A pipeline with exact, fixed results for testing the firmware's runtime, console and link: it
// counts frames at 30 Hz while mapping, reports the rig moving for 2 s after each scan start and
// still afterwards, and "localises" in 0.1 s to a fixed set of object poses (kSimObjects). The
// test program edgefused_exact_poses runs the firmware with it (tests/firmware/).
#pragma once

#include "edgefuse/runtime/pipeline.hpp"

namespace edgefuse_test {

using namespace edgefuse;

struct SimObject {
  const char* model;
  float tq[7];  //!< T_world_object: translation (m), quaternion x y z w
  float score;
};
//! The simulated bin's objects (printed by `model list`, sent as poses).
extern const SimObject kSimObjects[3];

class ExactPosePipeline : public runtime::Pipeline {
 public:
  bool start_mapping(const char** why) override;
  void stop_mapping() override { mapping_ = false; }
  void reset_map() override { map_frames_ = 0; }
  void step(uint64_t now_us) override;
  bool start_localization(uint64_t now_us, const char** why) override;
  bool poll_localization(runtime::LocalizationOutcome& out) override;
  bool calibrate_pair(const char* from, const char* to, runtime::PairCalibrationReport& out,
                      const char** why) override;
  runtime::PipelineStats stats() const override { return stats_; }
  bool map_empty() const override { return map_frames_ == 0; }
  int device_count() const override { return 3; }
  const char* device_name(int i) const override;
  const char* device_state(int) const override { return "simulated"; }
  int model_count() const override { return 3; }
  const char* model_name(int i) const override { return kSimObjects[i].model; }

 private:
  bool mapping_ = false;
  bool localizing_ = false;
  uint64_t now_us_ = 0;
  uint64_t mapping_since_us_ = 0;
  uint64_t last_frame_us_ = 0;
  uint64_t localize_done_us_ = 0;
  uint64_t capture_us_ = 0;
  uint32_t map_frames_ = 0;
  runtime::PipelineStats stats_;
};

}  // namespace edgefuse_test
