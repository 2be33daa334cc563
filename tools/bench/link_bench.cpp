// Pose-link benchmark: CPU time to encode + frame a result and to stream-decode + protobuf-decode
// it, for 3 and 32 objects, and the frame sizes (which set the serial transfer time).
// usage: link_bench [iterations]
#include <time.h>

#include <cstdio>
#include <cstdlib>

#include "edgefuse/link/messages.hpp"

using namespace edgefuse;
using namespace edgefuse::link;

namespace {

double cpu_s() {
  timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

FrameWriter g_writer;
StaticStreamDecoder<kMaxPayload> g_decoder;
Message g_msg, g_out;

void run(int objects, int iterations) {
  g_msg = make_result(1, 123456789);
  for (int i = 0; i < objects; ++i) {
    const Pose p = Pose::from_tq(0.4f + 0.01f * i, -0.1f, 0.03f, 0, 0, 0.2588f, 0.9659f);
    add_object(g_msg.body.result, uint32_t(i + 1), p, 0.9f, p.t, Vec3f(0, 0, -1));
  }
  size_t n = 0;
  volatile size_t sink = 0;
  double t0 = cpu_s();
  for (int k = 0; k < iterations; ++k) {
    g_msg.body.result.seq = uint32_t(k);
    sink = sink + (g_writer.encode(g_msg, n) != nullptr);
  }
  const double enc_us = (cpu_s() - t0) / iterations * 1e6;
  const uint8_t* f = g_writer.encode(g_msg, n);
  int ok = 0;
  t0 = cpu_s();
  for (int k = 0; k < iterations; ++k)
    for (size_t i = 0; i < n; ++i)
      if (g_decoder.push(f[i]) && decode_message(g_decoder.payload(), g_decoder.payload_size(), g_out)) ++ok;
  const double dec_us = (cpu_s() - t0) / iterations * 1e6;
  std::printf("objects=%-3d frame_bytes=%-5zu encode_us=%.2f decode_us=%.2f serial_115200_ms=%.1f decoded=%d/%d\n",
              objects, n, enc_us, dec_us, double(n) * 10.0 / 115200.0 * 1000.0, ok, iterations);
}

}  // namespace

int main(int argc, char** argv) {
  const int iterations = argc > 1 ? std::atoi(argv[1]) : 20000;
  if (iterations <= 0) {
    std::fprintf(stderr, "usage: link_bench [iterations > 0]\n");
    return 2;
  }
  run(0, iterations);
  run(3, iterations);
  run(32, iterations);
  return 0;
}
