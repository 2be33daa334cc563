// edgefused: the on-board runtime. Reads the board and the runtime configuration, opens the console
// and the pose link (serial / pseudo-terminal, TCP server, UDP), and runs the state machine
// IDLE -> MAPPING -> LOCALIZE -> REPORT in one poll loop. SIGTERM/SIGINT stop it cleanly; under
// systemd it reports READY and feeds the watchdog. Everything is allocated before the loop.
//
//   edgefused [--board NAME] [--config FILE] [--set KEY=VALUE]... [--check]
#include <poll.h>
#include <signal.h>
#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>

#include "board_defaults.hpp"
#include "edgefuse/hal/platform/serial_sockets/serial_port.hpp"
#include "edgefuse/hal/platform/serial_sockets/sockets.hpp"
#include "edgefuse/hal/platform/config/calib_file_store.hpp"
#include "edgefuse/hal/platform/config/config_toml.hpp"
#include "edgefuse/hal/platform/systemd/sd_notify.hpp"
#include "edgefuse/link/publisher.hpp"
#include "edgefuse/memory/arena.hpp"
#include "edgefuse/runtime/console.hpp"
#include "edgefuse/runtime/runtime.hpp"
#include "fusion_pipeline.hpp"
#include "sim_pipeline.hpp"

using namespace edgefuse;

namespace {

const char* kUsage =
    "usage: edgefused [--board NAME] [--config FILE] [--set KEY=VALUE]... [--check]\n"
    "  --board NAME     board folder under board/ (default: the build's board)\n"
    "  --config FILE    runtime configuration (TOML); every key is a parameter (param get lists them)\n"
    "  --set KEY=VALUE  override one parameter, e.g. --set link.tcp_port=6000 (repeatable)\n"
    "  --check          check the board data, the configuration and the --set values, print\n"
    "                   'configuration OK' and exit 0 (1 with the error) without opening devices or ports\n";

volatile sig_atomic_t g_stop = 0;
void on_signal(int sig) { g_stop = sig; }

uint64_t now_us() {
  timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return uint64_t(t.tv_sec) * 1000000u + uint64_t(t.tv_nsec) / 1000u;
}

// A port of the console or link: a pseudo-terminal (host-sim), a serial device, or none.
struct Port {
  hal::PtyPair pty;
  int fd = -1;  // what the program reads and writes
  std::string name;
};

bool open_port(const char* what, const std::string& spec, int baud, Port& p, std::string& err) {
  if (spec.empty()) return true;
  if (spec == "pty") {
    if (!hal::pty_open(p.pty, err)) return false;
    p.fd = p.pty.controller;
    p.name = p.pty.terminal_name;
  } else {
    if (!hal::baud_supported(baud)) {
      err = std::string(what) + ".baud = " + std::to_string(baud) + " is not a standard rate";
      return false;
    }
    p.fd = hal::serial_open(spec.c_str(), baud, err);
    if (p.fd < 0) return false;
    p.name = spec;
  }
  return true;
}

void close_port(Port& p) {
  if (p.pty.controller >= 0)
    hal::pty_close(p.pty);
  else if (p.fd >= 0)
    ::close(p.fd);
  p.fd = -1;
}

// Sends every frame to the link's serial port, the TCP clients and the UDP destination.
class LinkFanout : public link::FrameSink {
 public:
  int serial_fd = -1;
  hal::TcpServer* tcp = nullptr;
  hal::UdpSender* udp = nullptr;
  uint32_t serial_drops = 0;
  bool serial_resync = false;  // a frame may have gone out cut short: a 0x00 ends it first
  void send(const uint8_t* frame, size_t len) override {
    if (serial_fd >= 0) {
      const uint8_t zero = 0;
      if (serial_resync) serial_resync = !hal::write_all(serial_fd, &zero, 1, 0);
      if (serial_resync || !hal::write_all(serial_fd, frame, len, 0)) {
        ++serial_drops;  // the line is full (nobody reading, or slower than the results)
        serial_resync = true;
      }
    }
    if (tcp != nullptr) tcp->broadcast(frame, len);
    if (udp != nullptr) udp->send(frame, len);
  }
};

class FdWriter : public runtime::ConsoleWriter {
 public:
  int fd = -1;
  LinkFanout* link = nullptr;  // set when the console shares the link's port
  void write(const char* s, size_t n) override {
    // On a shared port the next frame starts with a 0x00, so a receiver drops this text as one
    // bad block and decodes the frame after it.
    if (link != nullptr) link->serial_resync = true;
    // A terminal that stopped reading must not stall the pipeline: wait at most 5 ms, then drop.
    if (fd >= 0) hal::write_all(fd, s, n, 5);
  }
};

class FileCalibStorage : public runtime::CalibrationStorage {
 public:
  explicit FileCalibStorage(hal::CalibFileStore& s) : store_(s) {}
  bool save(const runtime::CalibrationData& d, char* msg, size_t cap) override {
    std::string err;
    const bool ok = store_.save(d, err);
    std::snprintf(msg, cap, "%s", ok ? "saved" : err.c_str());
    return ok;
  }
  bool load(runtime::CalibrationData& d, char* msg, size_t cap) override {
    hal::CalibLoadReport rep;
    const bool ok = store_.load(d, rep);
    std::snprintf(msg, cap, "%s", rep.message.c_str());
    return ok;
  }

 private:
  hal::CalibFileStore& store_;
};

// Static: nothing of the runtime lives on the heap.
runtime::ParamStore g_params;
sim::SimPipeline g_sim_pipeline;    // pipeline.source = simulated: fixed test poses
wire::FusionPipeline g_fusion;      // pipeline.source = fusion (default): HAL -> TSDF -> localisation
LinkFanout g_link;
link::LinkPublisher g_publisher(g_link);
FdWriter g_console_out;
hal::TcpServer g_tcp;
hal::UdpSender g_udp;
char g_buf[4096];

}  // namespace

int main(int argc, char** argv) {
  std::string board = build_board().name, config, err;
  std::string overrides[64];
  int override_count = 0;
  bool check_only = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::printf("%s", kUsage);
      return 0;
    }
    if ((a == "--board" || a == "--config" || a == "--set") && i + 1 >= argc) {
      std::fprintf(stderr, "edgefused: %s needs a value\n%s", a.c_str(), kUsage);
      return 2;
    }
    if (a == "--board") {
      board = argv[++i];
    } else if (a == "--config") {
      config = argv[++i];
    } else if (a == "--check") {
      check_only = true;
    } else if (a == "--set") {
      if (override_count == 64) {
        std::fprintf(stderr, "edgefused: more than 64 --set options\n");
        return 2;
      }
      overrides[override_count++] = argv[++i];
    } else {
      std::fprintf(stderr, "edgefused: unknown argument '%s'\n%s", a.c_str(), kUsage);
      return 2;
    }
  }
  if (find_board(board.c_str()) == nullptr) {
    std::fprintf(stderr, "edgefused: unknown board '%s'; known:", board.c_str());
    for (int i = 0; i < board_count(); ++i) std::fprintf(stderr, " %s", board_at(i).name);
    std::fprintf(stderr, "\n");
    return 1;
  }
  // Board data first (its [tsdf] defaults), then the config file, then --set: later wins.
  {
    cli::BoardDefaults bd;
    if (!cli::read_board_defaults(board, bd, err)) {
      std::fprintf(stderr, "edgefused: %s\n", err.c_str());
      return 1;
    }
    char text[32], e[200];
    std::snprintf(text, sizeof(text), "%.9g", double(bd.voxel_m));
    const bool ok = g_params.set(runtime::kTsdfVoxelM, text, e, sizeof(e));
    std::snprintf(text, sizeof(text), "%.9g", double(bd.trunc_m));
    if (!ok || !g_params.set(runtime::kTsdfTruncM, text, e, sizeof(e))) {
      std::fprintf(stderr, "edgefused: board/%s/board.toml: %s\n", board.c_str(), e);
      return 1;
    }
  }
  if (!config.empty() && !hal::load_config_toml(config, g_params, err)) {
    std::fprintf(stderr, "edgefused: %s\n", err.c_str());
    return 1;
  }
  for (int i = 0; i < override_count; ++i)
    if (!hal::apply_override(overrides[i], g_params, err)) {
      std::fprintf(stderr, "edgefused: %s\n", err.c_str());
      return 1;
    }
  const std::string console_spec = g_params.get_text(runtime::kConsoleSerial);
  const std::string link_spec = g_params.get_text(runtime::kLinkSerial);
  // console.serial = "link" shares the link's port; naming the same device twice is a mistake.
  const bool shared = console_spec == "link";
  if (shared && link_spec.empty()) {
    std::fprintf(stderr, "edgefused: console.serial = link, but link.serial is off\n");
    return 1;
  }
  if (!console_spec.empty() && console_spec != "pty" && console_spec == link_spec) {
    std::fprintf(stderr, "edgefused: console.serial and link.serial are both %s; write console.serial = \"link\" "
                 "to share the link's port\n", console_spec.c_str());
    return 1;
  }
  const std::string source = g_params.get_text(runtime::kPipelineSource);
  if (source != "fusion" && source != "simulated") {
    std::fprintf(stderr, "edgefused: pipeline.source = '%s' is not one of fusion|simulated\n", source.c_str());
    return 1;
  }
  const std::string poses = g_params.get_text(runtime::kTrackingPoses);
  if (poses != "known" && poses != "tracked" && poses != "auto") {
    std::fprintf(stderr, "edgefused: tracking.poses = '%s' is not one of auto|known|tracked\n", poses.c_str());
    return 1;
  }
  std::printf("edgefused %s: board %s, config %s, voxel %g m, truncation %g m\n", PROJECT_VERSION, board.c_str(),
              config.empty() ? "(defaults)" : config.c_str(), g_params.get_number(runtime::kTsdfVoxelM),
              g_params.get_number(runtime::kTsdfTruncM));
  if (check_only) {  // everything above reads files only; the devices, ports and files below are not touched
    std::printf("configuration OK\n");
    return 0;
  }
  // The pipeline: the real one (devices from the board's hal.toml) or the simulated pose source.
  runtime::Pipeline* pipeline = &g_fusion;
  if (source == "simulated") {
    pipeline = &g_sim_pipeline;
    std::printf("pipeline: simulated pose source (%d fixed objects)\n", int(sizeof(sim::kSimObjects) / sizeof(sim::kSimObjects[0])));
  } else {  // "fusion" (the source was checked above)
    wire::FusionPipelineConfig fc;
    fc.board = board;
    fc.replay = g_params.get_text(runtime::kSensorsReplay);
    fc.models = g_params.get_text(runtime::kLocalizeModels);
    fc.voxel_m = float(g_params.get_number(runtime::kTsdfVoxelM));
    fc.trunc_m = float(g_params.get_number(runtime::kTsdfTruncM));
    fc.bilateral = g_params.get_bool(runtime::kFiltersBilateral);
    fc.tracked = poses == "tracked";
    fc.auto_poses = poses == "auto";
    fc.push_every_frame = g_params.get_bool(runtime::kTrackingPushEveryFrame);
    fc.fuse = g_params.get_text(runtime::kSensorsFuse);
    fc.replay_speed = g_params.get_number(runtime::kSensorsReplaySpeed);
    if (!g_fusion.init(fc, err)) {
      std::fprintf(stderr, "edgefused: %s\n", err.c_str());
      return 1;
    }
  }

  // Calibration: the newest valid slot, a corrupt one reported.
  static hal::CalibFileStore store(g_params.get_text(runtime::kCalibDir));
  static FileCalibStorage storage(store);
  static runtime::Runtime rt(*pipeline, g_params, storage, g_publisher);
  {
    runtime::CalibrationData d;
    hal::CalibLoadReport rep;
    if (store.load(d, rep)) rt.set_calibration(d);
    std::printf("%s\n", rep.message.c_str());
  }

  // Ports.
  Port console_port, link_port;
  if (!open_port("console", shared ? "" : console_spec, g_params.get_int(runtime::kConsoleBaud), console_port,
                 err) ||
      !open_port("link", link_spec, g_params.get_int(runtime::kLinkBaud), link_port, err)) {
    std::fprintf(stderr, "edgefused: %s\n", err.c_str());
    return 1;
  }
  if (console_port.fd >= 0) std::printf("console: %s\n", console_port.name.c_str());
  if (shared) std::printf("console: %s (shared with the link)\n", link_port.name.c_str());
  if (link_port.fd >= 0) std::printf("link: %s\n", link_port.name.c_str());
  if (g_params.get_bool(runtime::kLinkTcp)) {
    if (!g_tcp.listen(g_params.get_text(runtime::kLinkTcpBind), g_params.get_int(runtime::kLinkTcpPort), err)) {
      std::fprintf(stderr, "edgefused: link.tcp_port: %s\n", err.c_str());
      return 1;
    }
    std::printf("tcp: %s:%d\n", g_params.get_text(runtime::kLinkTcpBind), g_tcp.port());
    g_link.tcp = &g_tcp;
  }
  if (g_params.get_text(runtime::kLinkUdpHost)[0] != '\0') {
    if (!g_udp.open(g_params.get_text(runtime::kLinkUdpHost), g_params.get_int(runtime::kLinkUdpPort), err)) {
      std::fprintf(stderr, "edgefused: link.udp_host: %s\n", err.c_str());
      return 1;
    }
    std::printf("udp: %s:%d\n", g_params.get_text(runtime::kLinkUdpHost), g_params.get_int(runtime::kLinkUdpPort));
    g_link.udp = &g_udp;
  }
  g_link.serial_fd = link_port.fd;
  g_console_out.fd = shared ? link_port.fd : console_port.fd;
  g_console_out.link = shared ? &g_link : nullptr;
  static runtime::Console console(rt, g_params, g_console_out, "edgefused " PROJECT_VERSION);
  console.set_echo(g_params.get_bool(runtime::kConsoleEcho));

  struct sigaction sa{};
  sa.sa_handler = on_signal;
  sigaction(SIGTERM, &sa, nullptr);
  sigaction(SIGINT, &sa, nullptr);
  signal(SIGPIPE, SIG_IGN);

  const uint64_t watchdog_us = hal::sd_watchdog_usec();
  uint64_t next_watchdog_us = 0;
  hal::sd_notify_send("READY=1");
  std::printf("ready\n");
  std::fflush(stdout);

  pollfd fds[3 + hal::TcpServer::kMaxClients];
  runtime::RuntimeState last_state = rt.state();
  uint32_t last_results = 0;
  while (!g_stop) {
    int n = 0;
    if (console_port.fd >= 0) fds[n++] = {console_port.fd, POLLIN, 0};
    if (link_port.fd >= 0) fds[n++] = {link_port.fd, POLLIN, 0};
    if (g_tcp.listen_fd() >= 0) fds[n++] = {g_tcp.listen_fd(), POLLIN, 0};
    for (int i = 0; i < hal::TcpServer::kMaxClients; ++i)
      if (g_tcp.client_fd(i) >= 0) fds[n++] = {g_tcp.client_fd(i), POLLIN, 0};
    ::poll(fds, nfds_t(n), 10);  // 10 ms: the pipeline's tick also runs when nothing arrives
    if (console_port.fd >= 0) {
      const ssize_t r = ::read(console_port.fd, g_buf, sizeof(g_buf));
      if (r > 0) console.feed(g_buf, size_t(r));
    }
    if (link_port.fd >= 0) {
      ssize_t r;
      while ((r = ::read(link_port.fd, g_buf, sizeof(g_buf))) > 0)
        if (shared) console.feed(g_buf, size_t(r));  // otherwise the link is output only: drain
    }
    g_tcp.service();
    const uint64_t t = now_us();
    rt.tick(t);
    if (rt.state() != last_state || rt.results_sent() != last_results) {
      // log.level info (2) and up: state changes; debug (3): every result.
      if (g_params.get_int(runtime::kLogLevel) >= 2 && rt.state() != last_state)
        std::printf("state: %s\n", runtime::to_string(rt.state()));
      if (g_params.get_int(runtime::kLogLevel) >= 3 && rt.results_sent() != last_results)
        std::printf("result: seq %u sent (tcp clients %d, serial drops %u)\n", unsigned(rt.results_sent() - 1),
                    g_tcp.client_count(), unsigned(g_link.serial_drops));
      std::fflush(stdout);
      last_state = rt.state();
      last_results = rt.results_sent();
    }
    if (watchdog_us > 0 && t >= next_watchdog_us) {
      hal::sd_notify_send("WATCHDOG=1");
      next_watchdog_us = t + watchdog_us / 2;
    }
  }
  hal::sd_notify_send("STOPPING=1");
  g_fusion.shutdown();
  std::printf("edgefused: stopped by %s after %u results\n", g_stop == SIGINT ? "SIGINT" : "SIGTERM",
              unsigned(rt.results_sent()));
  std::fflush(stdout);
  g_tcp.close();
  g_udp.close();
  close_port(console_port);
  close_port(link_port);
  return 0;
}
