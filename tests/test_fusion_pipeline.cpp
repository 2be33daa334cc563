// edgefused's real pipeline (tools/edgefused/fusion_pipeline.cpp) on host-sim's sim backend: frames
// through the HAL, filters, known or tracked poses, integration and a model-free localisation, with
// no heap allocation once started (mapping, tracking and the localisation thread), and the states
// the runtime sees (empty map refused, tracking state, still detection off while the rig moves).
#include <time.h>

#include <memory>
#include <string>

#include "alloc_counter.hpp"
#include "edgefuse/board_config.hpp"
#include "fusion_pipeline.hpp"

#include <CppUTest/TestHarness.h>

using namespace edgefuse;

namespace {

uint64_t now_us() {
  timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return uint64_t(t.tv_sec) * 1000000u + uint64_t(t.tv_nsec) / 1000u;
}

void sleep_ms(int ms) {
  timespec t{0, long(ms) * 1000000L};
  nanosleep(&t, nullptr);
}

// Steps until `frames` more frames were processed (at most 60 s).
bool step_frames(wire::FusionPipeline& p, uint32_t frames) {
  const uint32_t target = p.stats().frames + frames;
  const uint64_t end = now_us() + 60000000u;
  while (p.stats().frames < target && now_us() < end) {
    p.step(now_us());
    sleep_ms(2);
  }
  return p.stats().frames >= target;
}

bool localize(wire::FusionPipeline& p, link::LocalizationResult& r) {
  const char* why = "";
  if (!p.start_localization(now_us(), &why)) return false;
  const uint64_t end = now_us() + 120000000u;
  while (now_us() < end) {
    p.step(now_us());
    if (p.poll_localization(r)) return true;
    sleep_ms(5);
  }
  return false;
}

void run_pipeline(bool tracked) {
  wire::FusionPipelineConfig c;
  c.board = kBuildBoard.name;
  c.tracked = tracked;
  c.push_every_frame = true;
  std::unique_ptr<wire::FusionPipeline> p(new wire::FusionPipeline);
  std::string err;
  CHECK_TRUE_TEXT(p->init(c, err), err.c_str());
  CHECK_EQUAL(0, p->model_count());  // no models configured, no replay: model-free segments
  CHECK_TRUE(p->map_empty());
  link::LocalizationResult r;
  const char* why = "";
  CHECK_FALSE(p->start_localization(now_us(), &why));  // nothing mapped yet
  STRCMP_EQUAL("the map is empty", why);

  CHECK_TRUE(p->start_mapping(&why));
  CHECK_TRUE(step_frames(*p, 3));  // warm-up: the first frame centres the volume
  CHECK_FALSE(p->map_empty());
  edgefuse_test::alloc_count_start();
  CHECK_TRUE(step_frames(*p, 5));
  const uint64_t still_since = p->stats().still_since_us;  // before localising: mapping pauses then
  const uint64_t mapped_us = now_us();
  CHECK_TRUE(localize(*p, r));
  const long allocations = edgefuse_test::alloc_count();
  CHECK_EQUAL(0L, allocations);

  CHECK_EQUAL(int(edgefuse_link_TrackingState_TRACKING_OK), int(p->stats().tracking));
  // The simulated rig sways on its circle at 2 pi 0.02 m / 8 s = 15.7 mm/s: it leaves the 1 mm
  // still tolerance within 64 ms, so it is never still for long (at any frame rate).
  CHECK_TRUE(still_since == 0 || mapped_us - still_since < 200000u);
  CHECK_EQUAL(int(edgefuse_link_ResultStatus_RESULT_OK), int(r.status));
  CHECK_TRUE(r.stamp_us > 0);
  CHECK_TRUE(r.objects_count >= 4);  // bin_rig_a's six objects as segments (some may merge)
  for (pb_size_t i = 0; i < r.objects_count; ++i) CHECK_EQUAL(0u, r.objects[i].id);
  p->stop_mapping();
  p->shutdown();
}

}  // namespace

TEST_GROUP(FusionPipeline){};

TEST(FusionPipeline, KnownPosesSegmentsWithoutHeap) { run_pipeline(false); }

TEST(FusionPipeline, TrackedPosesSegmentsWithoutHeap) { run_pipeline(true); }
