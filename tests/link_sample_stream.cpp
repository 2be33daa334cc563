// Writes a captured pose-link stream for the listener tests: results with 0..32 objects,
// heartbeats, line noise and two corrupted frames (which both listeners must skip and count).
// usage: link_sample_stream OUT.bin
#include <cstdio>
#include <vector>

#include "edgefuse/link/messages.hpp"

using namespace edgefuse;
using namespace edgefuse::link;

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: link_sample_stream OUT.bin\n");
    return 2;
  }
  static FrameWriter w;
  static Message m;
  std::vector<uint8_t> s = {0x42, 0x13, 0x00};  // noise before the first frame: one COBS/CRC error
  for (uint32_t k = 0; k < 12; ++k) {
    if (k % 4 == 0) {
      m = make_heartbeat(k / 4, 1000000ull * k);
      m.body.heartbeat.state = edgefuse_link_RuntimeState(k / 4 % 4);
      m.body.heartbeat.tracking = edgefuse_link_TrackingState_TRACKING_OK;
      m.body.heartbeat.fps = 29.75f;
      m.body.heartbeat.frames = 30 * k;
      m.body.heartbeat.uptime_s = k;
    } else {
      m = make_result(k, 1000000ull * k + 333);
      const int objects = k == 11 ? int(kMaxObjects) : int(k % 4);
      for (int i = 0; i < objects; ++i) {
        const Pose p = Pose::from_tq(0.01f * i - 0.1f, 0.02f * k, 0.65f + 0.001f * i, 0.0f, 0.7071f * (i % 2),
                                     0.1f * k, 1.0f);
        add_object(m.body.result, uint32_t(i + 1), p, 1.0f / float(i + 2), p.t, Vec3f(0, 0, -1));
      }
      if (k == 6) m.body.result.status = edgefuse_link_ResultStatus_RESULT_NO_OBJECTS;
    }
    size_t n = 0;
    const uint8_t* f = w.encode(m, n);
    if (f == nullptr) return 1;
    std::vector<uint8_t> frame(f, f + n);
    if (k == 3 || k == 9) frame[n / 2] = frame[n / 2] == 0x55 ? 0x56 : 0x55;  // corrupt (never 0x00)
    s.insert(s.end(), frame.begin(), frame.end());
  }
  std::FILE* out = std::fopen(argv[1], "wb");
  if (out == nullptr || std::fwrite(s.data(), 1, s.size(), out) != s.size() || std::fclose(out) != 0) {
    std::perror(argv[1]);
    return 1;
  }
  return 0;
}
