// Pairs frames of two rigidly mounted sensors (e.g. xtion + tof) by nearest stamp within a window:
// the newest frame of stream A is matched with the ready frame of B nearest to it in time. A frame
// that is older than the other stream's by more than the window can never be matched later (the
// other stream only brings newer frames), so it is returned unpaired and counted. The streams'
// delivery latencies must differ by less than what the faster stream's channel holds (its slots
// times its frame period), else the late stream's frames find no partner left.
#pragma once

#include <cstdint>

#include "edgefuse/hal/acquisition/frame_channel.hpp"

namespace edgefuse::hal {

struct FramePair {
  const DepthFrame* a = nullptr;
  const DepthFrame* b = nullptr;
};

class FramePairer {
 public:
  //! \param a first stream  \param b second stream  \param window_us largest stamp difference of a pair
  FramePairer(FrameChannel& a, FrameChannel& b, uint32_t window_us) : a_(a), b_(b), window_us_(window_us) {}
  //! Takes what is ready and returns a pair when one is complete (held until release()).
  //! \param pair receives both frames
  bool poll(FramePair& pair);
  //! Returns a pair's frames to their streams.
  //! \param pair the pair from poll()
  void release(FramePair& pair);
  //! Returns frames still waiting for a partner.
  void reset();

  uint32_t pairs() const { return pairs_; }
  uint32_t unpaired_a() const { return unpaired_a_; }
  uint32_t unpaired_b() const { return unpaired_b_; }

 private:
  static uint64_t diff(uint64_t x, uint64_t y) { return x > y ? x - y : y - x; }

  FrameChannel& a_;
  FrameChannel& b_;
  uint32_t window_us_;
  const DepthFrame* held_a_ = nullptr;
  const DepthFrame* held_b_ = nullptr;
  uint32_t pairs_ = 0, unpaired_a_ = 0, unpaired_b_ = 0;
};

}  // namespace edgefuse::hal
