// edgefuse listen: the robot-controller side of the pose link. Connects to a serial port, a TCP
// server or a UDP port (or reads a captured stream from a file), decodes the frames and prints
// results and heartbeats; --csv prints one line per object. Protocol: docs/PROTOCOL.md.
#include <fcntl.h>
#include <poll.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <string>

#include "failure.hpp"
#include "args.hpp"
#include "commands.hpp"
#include "edgefuse/hal/platform/serial_sockets/serial_port.hpp"
#include "edgefuse/hal/platform/serial_sockets/sockets.hpp"
#include "edgefuse/link/messages.hpp"

namespace edgefuse::cli {
namespace {

const char* kUsage =
    "usage: edgefuse listen (--serial DEV [--baud B] | --tcp HOST:PORT | --udp PORT | --file PATH)\n"
    "                       [--csv] [--count N] [--timeout-s S]\n"
    "  --csv          one line per object: seq,stamp_us,id,tx,ty,tz,qx,qy,qz,qw,score\n"
    "                 (metres, object-to-world, quaternion x y z w)\n"
    "  --count N      exit after N localisation results\n"
    "  --timeout-s S  exit with an error when no valid frame arrived for S seconds\n";

const char* status_name(int s) {
  switch (s) {
    case edgefuse_link_ResultStatus_RESULT_OK: return "OK";
    case edgefuse_link_ResultStatus_RESULT_NO_OBJECTS: return "NO_OBJECTS";
    case edgefuse_link_ResultStatus_RESULT_FAILED: return "FAILED";
    case edgefuse_link_ResultStatus_RESULT_TRACKING_LOST: return "TRACKING_LOST";
  }
  return "UNKNOWN";
}
const char* state_name(int s) {
  static const char* const k[] = {"IDLE", "MAPPING", "LOCALIZE", "REPORT", "ERROR"};
  return s >= 0 && s < 5 ? k[s] : "UNKNOWN";
}
const char* tracking_name(int s) {
  static const char* const k[] = {"OFF", "OK", "DEGRADED", "LOST"};
  return s >= 0 && s < 4 ? k[s] : "UNKNOWN";
}

// Prints a message; tools/listen.py prints the same lines (tested).
void print_message(const link::Message& m, bool csv) {
  if (m.which_body == edgefuse_link_Message_result_tag) {
    const link::LocalizationResult& r = m.body.result;
    if (!csv)
      std::printf("result seq=%" PRIu32 " stamp_us=%" PRIu64 " status=%s objects=%u\n", r.seq, r.stamp_us,
                  status_name(r.status), unsigned(r.objects_count));
    for (unsigned i = 0; i < r.objects_count; ++i) {
      const link::ObjectPose& o = r.objects[i];
      if (csv)
        std::printf("%" PRIu32 ",%" PRIu64 ",%" PRIu32 ",%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.4f\n", r.seq, r.stamp_us,
                    o.id, o.position_m.x, o.position_m.y, o.position_m.z, o.orientation.x, o.orientation.y,
                    o.orientation.z, o.orientation.w, o.score);
      else
        std::printf("  id=%" PRIu32 " t=%.6f,%.6f,%.6f q=%.6f,%.6f,%.6f,%.6f score=%.4f grasp=%.6f,%.6f,%.6f "
                    "approach=%.4f,%.4f,%.4f\n",
                    o.id, o.position_m.x, o.position_m.y, o.position_m.z, o.orientation.x, o.orientation.y,
                    o.orientation.z, o.orientation.w, o.score, o.grasp_point_m.x, o.grasp_point_m.y,
                    o.grasp_point_m.z, o.approach.x, o.approach.y, o.approach.z);
    }
  } else if (m.which_body == edgefuse_link_Message_heartbeat_tag && !csv) {
    const link::Heartbeat& h = m.body.heartbeat;
    std::printf("heartbeat seq=%" PRIu32 " stamp_us=%" PRIu64 " protocol=%" PRIu32 " state=%s tracking=%s fps=%.1f "
                "frames=%" PRIu32 " drops=%" PRIu32 " results=%" PRIu32 " uptime_s=%" PRIu32 "\n",
                h.seq, h.stamp_us, h.protocol_version, state_name(h.state), tracking_name(h.tracking), h.fps, h.frames,
                h.drops, h.results, h.uptime_s);
  }
  std::fflush(stdout);
}

double now_s() {
  timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

// Static: a Message with 32 objects is a few KiB.
link::StaticStreamDecoder<link::kMaxPayload> g_decoder;
link::Message g_message;
uint8_t g_buf[65536];




// What the command line asks for.
struct ListenOptions {
  Args args;
  int baud = 115200, count = 0, udp_port = 0;
  float timeout_s = 0;
  bool csv = false;
};

bool parse_options(int argc, char** argv, ListenOptions& o, Failure& f) {
  const Args& args = o.args;
  std::string err;
  f.usage = true;
  if (!o.args.parse(argc, argv, {"serial", "baud", "tcp", "udp", "file", "count", "timeout-s"}, {"csv"}, err) ||
      !args.positional().empty())
    return fail(f, err.empty() ? "unexpected argument" : err, 2);
  const int sources = args.has("serial") + args.has("tcp") + args.has("udp") + args.has("file");
  if (sources != 1) return fail(f, "give exactly one of --serial, --tcp, --udp, --file", 2);
  f.usage = false;
  if ((args.has("baud") && !args.get_int("baud", 1200, 4000000, o.baud, err)) ||
      (args.has("count") && !args.get_int("count", 1, 1 << 30, o.count, err)) ||
      (args.has("udp") && !args.get_int("udp", 1, 65535, o.udp_port, err)) ||
      (args.has("timeout-s") && !args.get_float("timeout-s", 0.01f, 1e6f, o.timeout_s, err)))
    return fail(f, err, 2);
  if (args.has("baud") && !hal::baud_supported(o.baud))
    return fail(f, "--baud " + std::to_string(o.baud) + " is not a standard rate (e.g. 9600, 115200, 921600)", 2);
  o.csv = args.has("csv");
  return true;
}

// Where the frames come from.
struct Source {
  int fd = -1;
  bool datagrams = false;  // UDP: one frame per datagram
  bool is_file = false;    // a captured stream: read to its end, no polling
};

bool open_source(const ListenOptions& o, Source& src, Failure& f) {
  const Args& args = o.args;
  std::string err;
  if (args.has("serial")) {
    src.fd = hal::serial_open(args.get("serial").c_str(), o.baud, err);
  } else if (args.has("tcp")) {
    std::string host;
    int port = 0;
    if (hal::parse_host_port(args.get("tcp"), host, port, err))
      src.fd = hal::tcp_connect(host.empty() ? "127.0.0.1" : host.c_str(), port, err);
  } else if (args.has("udp")) {
    src.fd = hal::udp_bind(o.udp_port, err);
    src.datagrams = true;
  } else {
    src.fd = ::open(args.get("file").c_str(), O_RDONLY | O_CLOEXEC);
    if (src.fd < 0) err = args.get("file") + ": " + std::strerror(errno);
    src.is_file = true;
  }
  if (src.fd < 0) return fail(f, err);
  return true;
}

// What arrived.
struct Counts {
  int results = 0, heartbeats = 0, bad_datagrams = 0, bad_payloads = 0;
  double last_frame_s = 0;  // when the last valid frame arrived (for --timeout-s)
};

void handle_payload(const uint8_t* p, size_t n, bool csv, Counts& c) {
  c.last_frame_s = now_s();
  if (!link::decode_message(p, n, g_message)) {
    ++c.bad_payloads;
    return;
  }
  if (g_message.which_body == edgefuse_link_Message_result_tag) ++c.results;
  if (g_message.which_body == edgefuse_link_Message_heartbeat_tag) ++c.heartbeats;
  print_message(g_message, csv);
}

enum class Wait { kReady, kAgain, kStop };

// Polls the link for 100 ms; rc = 1 when --timeout-s passed without a valid frame.
Wait wait_for_data(const ListenOptions& o, const Source& src, const Counts& c, int& rc) {
  pollfd pfd{src.fd, POLLIN, 0};
  const int pr = ::poll(&pfd, 1, 100);
  if (pr < 0 && errno != EINTR) return Wait::kStop;
  if (pr > 0) return Wait::kReady;
  if (o.timeout_s > 0 && now_s() - c.last_frame_s > o.timeout_s) {
    std::fprintf(stderr, "edgefuse listen: no valid frame for %.1f s\n", double(o.timeout_s));
    rc = 1;
    return Wait::kStop;
  }
  return Wait::kAgain;
}

// n bytes read: one datagram, or a piece of the stream (decoded up to --count results).
void decode_bytes(const ListenOptions& o, const Source& src, ssize_t n, Counts& c) {
  if (src.datagrams) {
    size_t len = 0;
    if (link::frame_decode_inplace(g_buf, size_t(n), len))
      handle_payload(g_buf, len, o.csv, c);
    else
      ++c.bad_datagrams;
    return;
  }
  for (ssize_t i = 0; i < n && (o.count == 0 || c.results < o.count); ++i)
    if (g_decoder.push(g_buf[i])) handle_payload(g_decoder.payload(), g_decoder.payload_size(), o.csv, c);
}

// Reads and prints until --count results, the end of a file, a closed link or the timeout; the exit code.
int listen_loop(const ListenOptions& o, const Source& src, Counts& c) {
  int rc = 0;
  c.last_frame_s = now_s();
  while (o.count == 0 || c.results < o.count) {
    if (!src.is_file) {
      const Wait w = wait_for_data(o, src, c, rc);
      if (w == Wait::kStop) break;
      if (w == Wait::kAgain) continue;
    }
    const ssize_t n = ::read(src.fd, g_buf, sizeof(g_buf));
    if (n < 0 && (errno == EAGAIN || errno == EINTR)) continue;
    if (n <= 0) {
      if (!src.is_file) {
        std::fprintf(stderr, "edgefuse listen: the link closed (%s)\n", n < 0 ? std::strerror(errno) : "end of stream");
        rc = 1;
      }
      break;
    }
    decode_bytes(o, src, n, c);
  }
  return rc;
}

void print_summary(const Counts& c) {
  const link::DecoderStats& s = g_decoder.stats();
  std::fprintf(stderr,
               "listen: %d results, %d heartbeats, crc_errors=%" PRIu32 " cobs_errors=%" PRIu32 " overruns=%" PRIu32
               " bad_datagrams=%d bad_payloads=%d\n",
               c.results, c.heartbeats, s.crc_errors, s.cobs_errors, s.overruns, c.bad_datagrams, c.bad_payloads);
}

}  // namespace

int cmd_listen(int argc, char** argv) {
  if (help_asked(argc, argv, kUsage)) return 0;
  ListenOptions o;
  Failure f;
  Source src;
  if (!parse_options(argc, argv, o, f) || !open_source(o, src, f)) return report("edgefuse listen", f, kUsage);
  Counts counts;
  int rc = listen_loop(o, src, counts);
  ::close(src.fd);
  print_summary(counts);
  if (o.count > 0 && counts.results < o.count && rc == 0) rc = 1;
  return rc;
}

}  // namespace edgefuse::cli
