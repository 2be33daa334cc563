// edgefused: the on-board runtime. Reads the board and the runtime configuration, opens the console
// and the pose link (serial / pseudo-terminal, TCP server, UDP), and runs the state machine
// IDLE -> MAPPING -> LOCALIZE -> REPORT in the platform's service loop. SIGTERM/SIGINT stop it
// cleanly; under systemd it reports READY and feeds the watchdog. Everything is allocated before
// the loop.
#include "edgefused.hpp"

#include <csignal>
#include <cstdio>
#include <string>

#include "device_pipeline.hpp"
#include "edgefuse/hal/platform/config/board_data_dir.hpp"
#include "edgefuse/hal/platform/config/board_defaults.hpp"
#include "edgefuse/hal/platform/config/calib_file_store.hpp"
#include "edgefuse/hal/platform/config/config_toml.hpp"
#include "edgefuse/hal/platform/service/event_loop.hpp"
#include "edgefuse/hal/platform/service/ports.hpp"
#include "edgefuse/hal/platform/clock/monotonic_clock.hpp"
#include "edgefuse/link/messages.hpp"
#include "edgefuse/link/publisher.hpp"
#include "edgefuse/link/robot_codec.hpp"
#include "edgefuse/link/text_profile.hpp"
#include "edgefuse/math/real.hpp"
#include "edgefuse/memory/arena.hpp"
#include "edgefuse/robot/robot_session.hpp"
#include "edgefuse/runtime/console.hpp"
#include "edgefuse/runtime/runtime.hpp"
#include "edgefuse/version.hpp"

namespace edgefuse::firmware {
namespace {

const char* kUsage =
    "usage: edgefused [--board NAME] [--board-dir DIR] [--config FILE] [--set KEY=VALUE]... [--check]\n"
    "       edgefused --version\n"
    "  --board NAME     the board, a folder of the board data (default: the build's board)\n"
    "  --board-dir DIR  the board data: one folder per board (default: <exe>/../share/edgefuse/board,\n"
    "                   /usr/share/edgefuse/board when installed; the source tree's board/ in a build tree)\n"
    "  --config FILE    runtime configuration (TOML); every key is a parameter (param get lists them)\n"
    "  --set KEY=VALUE  override one parameter, e.g. --set link.tcp_port=6000 (repeatable)\n"
    "  --check          check the board data, the configuration and the --set values, print\n"
    "                   'configuration OK' and exit 0 (1 with the error) without opening devices or ports\n"
    "  --version        print the version, the board, the numeric build and the link protocol version\n";

struct CommandLine {
  std::string board = build_board().name;
  std::string board_dir;  //!< "" : searched (board_data_dir.hpp)
  std::string config;
  std::string overrides[64];
  int override_count = 0;
  bool check_only = false;
};

// Static: nothing of the runtime lives on the heap.
runtime::ParamStore g_params;
DevicePipeline g_devices;
hal::LinkFanout g_link;
link::LinkPublisher g_publisher(g_link);
hal::TcpServer g_tcp;
hal::TcpServer g_text('\n');  // a reply line cut short for a slow client is ended before the next
hal::UdpSender g_udp;

// The robot's requests at the link's edge: protobuf frames from the link's TCP clients (clients
// 0..7) and its serial line (kSerialClient), text lines from the text port's clients
// (kTextClientBase + slot); each reply goes back to the client that asked.
class RobotLink final : public robot::ReplySink, public link::RequestHandler {
 public:
  static constexpr int kSerialClient = hal::TcpServer::kMaxClients;
  static constexpr int kTextClientBase = 16;
  static_assert(link::RequestStreams::kStreams == kSerialClient + 1, "a frame stream per TCP client and the serial line");

  robot::RobotSession* session = nullptr;
  link::TextFormat default_format;  //!< robot.units / robot.rotation

  void frames(int client, const uint8_t* data, size_t n) { streams_.feed(client, data, n, *this); }
  void text(int slot, const uint8_t* data, size_t n) {
    for (size_t i = 0; i < n; ++i) {
      const link::TextLineBuffer::Event e = lines_[slot].push(char(data[i]));
      if (e == link::TextLineBuffer::Event::kNone) continue;
      if (e == link::TextLineBuffer::Event::kTooLong) {
        parsed_ = link::TextLine();
        parsed_.kind = link::TextLine::Kind::kRequest;
        parsed_.request.error = "line longer than 255 characters";
      } else {
        link::parse_text_line(lines_[slot].line(), lines_[slot].size(), formats_[slot], parsed_);
      }
      if (parsed_.kind == link::TextLine::Kind::kRequest) request(kTextClientBase + slot, parsed_.request);
      if (parsed_.kind == link::TextLine::Kind::kFormat) {
        formats_[slot] = parsed_.format;
        g_text.send_to(slot, reinterpret_cast<const uint8_t*>("OK\n"), 3);
      }
    }
  }
  void frames_closed(int client) {
    streams_.reset(client);
    session->client_closed(client);
  }
  void text_closed(int slot) {
    lines_[slot].reset();
    formats_[slot] = default_format;
    session->client_closed(kTextClientBase + slot);
  }
  void reset_formats() {
    for (link::TextFormat& f : formats_) f = default_format;
  }
  void request(int client, const robot::Request& r) override {
    session->handle(client, r, hal::monotonic_clock().now_us());
  }
  void reply(int client, const robot::Reply& r) override {
    if (client >= kTextClientBase) {
      const size_t n = link::format_text_reply(r, formats_[client - kTextClientBase], line_, sizeof(line_));
      if (n > 0) g_text.send_to(client - kTextClientBase, reinterpret_cast<const uint8_t*>(line_), n);
      return;
    }
    size_t n = 0;
    const uint8_t* f = writer_.encode(r, n);
    if (f == nullptr) return;
    if (client == kSerialClient)
      g_link.send_serial(f, n);
    else
      g_tcp.send_to(client, f, n);
  }

 private:
  link::RequestStreams streams_;
  link::ReplyWriter writer_;
  link::TextLineBuffer lines_[hal::TcpServer::kMaxClients];
  link::TextFormat formats_[hal::TcpServer::kMaxClients];
  link::TextLine parsed_;
  char line_[link::kTextReplyMax];
};
RobotLink g_robot;

class FrameInput final : public hal::TcpInput {
 public:
  void received(int client, const uint8_t* data, size_t n) override { g_robot.frames(client, data, n); }
  void closed(int client) override { g_robot.frames_closed(client); }
};
class TextInput final : public hal::TcpInput {
 public:
  void received(int client, const uint8_t* data, size_t n) override { g_robot.text(client, data, n); }
  void closed(int client) override { g_robot.text_closed(client); }
};
FrameInput g_frame_input;
TextInput g_text_input;

// One "key: value" per line after the first, for people and for scripts (the package tests).
void print_version() {
  std::printf("edgefused %s\nboard: %s\nnumeric: %s\nprotocol: %d\n", kVersion, build_board().name,
              kFixedPointBuild ? "fixed-point Q16.16" : "float",
              int(edgefuse_link_ProtocolVersion_PROTOCOL_VERSION_CURRENT));
}

// \return -1 to go on, else the exit code (--help: 0, a bad argument: 2)
int parse_command_line(int argc, char** argv, CommandLine& c) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::printf("%s", kUsage);
      return 0;
    }
    if (a == "--version") {
      print_version();
      return 0;
    }
    if ((a == "--board" || a == "--board-dir" || a == "--config" || a == "--set") && i + 1 >= argc) {
      std::fprintf(stderr, "edgefused: %s needs a value\n%s", a.c_str(), kUsage);
      return 2;
    }
    if (a == "--board") {
      c.board = argv[++i];
    } else if (a == "--board-dir") {
      c.board_dir = argv[++i];
    } else if (a == "--config") {
      c.config = argv[++i];
    } else if (a == "--check") {
      c.check_only = true;
    } else if (a == "--set") {
      if (c.override_count == 64) {
        std::fprintf(stderr, "edgefused: more than 64 --set options\n");
        return 2;
      }
      c.overrides[c.override_count++] = argv[++i];
    } else {
      std::fprintf(stderr, "edgefused: unknown argument '%s'\n%s", a.c_str(), kUsage);
      return 2;
    }
  }
  return -1;
}

// Board data first (its [tsdf] defaults), then the config file, then --set: later wins.
bool load_parameters(const CommandLine& c, std::string& err) {
  if (find_board(c.board.c_str()) == nullptr) {
    err = "unknown board '" + c.board + "'; known:";
    for (int i = 0; i < board_count(); ++i) err += std::string(" ") + board_at(i).name;
    return false;
  }
  hal::set_board_data_dir(c.board_dir);
  hal::BoardDefaults bd;
  if (!hal::read_board_defaults(c.board, bd, err)) return false;
  char text[32], e[200];
  std::snprintf(text, sizeof(text), "%d", bd.dim);
  bool ok = g_params.set(runtime::kTsdfDim, text, e, sizeof(e));
  std::snprintf(text, sizeof(text), "%.9g", double(bd.voxel_m));
  ok = ok && g_params.set(runtime::kTsdfVoxelM, text, e, sizeof(e));
  std::snprintf(text, sizeof(text), "%.9g", double(bd.trunc_m));
  if (!ok || !g_params.set(runtime::kTsdfTruncM, text, e, sizeof(e))) {
    err = "board/" + c.board + "/board.toml: " + e;
    return false;
  }
  if (!c.config.empty() && !hal::load_config_toml(c.config, g_params, err)) return false;
  for (int i = 0; i < c.override_count; ++i)
    if (!hal::apply_override(c.overrides[i], g_params, err)) return false;
  return true;
}

// Values whose combination is wrong (each alone passed its own check).
bool check_combinations(const std::string& board, std::string& err) {
  if (!hal::check_space_dim(board, g_params.get_int(runtime::kTsdfDim), "tsdf.dim", err)) return false;
  const std::string console_spec = g_params.get_text(runtime::kConsoleSerial);
  const std::string link_spec = g_params.get_text(runtime::kLinkSerial);
  // console.serial = "link" shares the link's port; naming the same device twice is a mistake.
  if (console_spec == "link" && link_spec.empty()) {
    err = "console.serial = link, but link.serial is off";
    return false;
  }
  if (!console_spec.empty() && console_spec != "pty" && console_spec == link_spec) {
    err = "console.serial and link.serial are both " + console_spec +
          "; write console.serial = \"link\" to share the link's port";
    return false;
  }
  const std::string poses = g_params.get_text(runtime::kTrackingPoses);
  CameraPoses mode;
  if (!parse_camera_poses(poses, mode)) {
    err = "tracking.poses = '" + poses + "' is not one of robot|robot+icp|icp|known (tracked = icp)";
    return false;
  }
  if (!link::parse_units(g_params.get_text(runtime::kRobotUnits), g_robot.default_format.units)) {
    err = std::string("robot.units = '") + g_params.get_text(runtime::kRobotUnits) + "' is not one of m|mm";
    return false;
  }
  if (!link::parse_rotation(g_params.get_text(runtime::kRobotRotation), g_robot.default_format.rotation)) {
    err = std::string("robot.rotation = '") + g_params.get_text(runtime::kRobotRotation) +
          "' is not one of xyzw|wxyz|axisangle|kuka_abc";
    return false;
  }
  g_robot.reset_formats();
  return true;
}

bool start_device_pipeline(const std::string& board, std::string& err) {
  DevicePipelineConfig fc;
  const std::string poses = g_params.get_text(runtime::kTrackingPoses);
  fc.board = board;
  fc.replay = g_params.get_text(runtime::kSensorsReplay);
  fc.models = g_params.get_text(runtime::kLocalizeModels);
  fc.dim = int(g_params.get_int(runtime::kTsdfDim));
  fc.voxel_m = float(g_params.get_number(runtime::kTsdfVoxelM));
  fc.trunc_m = float(g_params.get_number(runtime::kTsdfTruncM));
  fc.bilateral = g_params.get_bool(runtime::kFiltersBilateral);
  parse_camera_poses(poses, fc.poses);  // checked by check_combinations
  fc.robot_latency_us = g_params.get_int(runtime::kRobotLatencyUs);
  fc.use_sim_truth = g_params.get_bool(runtime::kTrackingSimTruth);
  fc.push_every_frame = g_params.get_bool(runtime::kTrackingPushEveryFrame);
  fc.fuse = g_params.get_text(runtime::kSensorsFuse);
  fc.replay_speed = g_params.get_number(runtime::kSensorsReplaySpeed);
  fc.sim_path = g_params.get_text(runtime::kSensorsSimPath);
  return g_devices.init(fc, err);
}

// The console, the link's serial port, TCP server and UDP destination.
bool open_ports(hal::Port& console, hal::Port& link_port, std::string& err) {
  const std::string console_spec = g_params.get_text(runtime::kConsoleSerial);
  const bool shared = console_spec == "link";
  if (!hal::open_port("console", shared ? "" : console_spec, g_params.get_int(runtime::kConsoleBaud), console, err) ||
      !hal::open_port("link", g_params.get_text(runtime::kLinkSerial), g_params.get_int(runtime::kLinkBaud), link_port,
                      err))
    return false;
  if (console.fd >= 0) std::printf("console: %s\n", console.name.c_str());
  if (shared) std::printf("console: %s (shared with the link)\n", link_port.name.c_str());
  if (link_port.fd >= 0) std::printf("link: %s\n", link_port.name.c_str());
  if (g_params.get_bool(runtime::kLinkTcp)) {
    if (!g_tcp.listen(g_params.get_text(runtime::kLinkTcpBind), g_params.get_int(runtime::kLinkTcpPort), err)) {
      err = "link.tcp_port: " + err;
      return false;
    }
    std::printf("tcp: %s:%d\n", g_params.get_text(runtime::kLinkTcpBind), g_tcp.port());
    g_link.tcp = &g_tcp;
    g_tcp.set_input(&g_frame_input);
  }
  if (g_params.get_bool(runtime::kRobotText)) {
    if (!g_text.listen(g_params.get_text(runtime::kLinkTcpBind), g_params.get_int(runtime::kRobotTextPort), err)) {
      err = "robot.text_port: " + err;
      return false;
    }
    std::printf("robot: %s:%d\n", g_params.get_text(runtime::kLinkTcpBind), g_text.port());
    g_text.set_input(&g_text_input);
  }
  if (g_params.get_text(runtime::kLinkUdpHost)[0] != '\0') {
    if (!g_udp.open(g_params.get_text(runtime::kLinkUdpHost), g_params.get_int(runtime::kLinkUdpPort), err)) {
      err = "link.udp_host: " + err;
      return false;
    }
    std::printf("udp: %s:%d\n", g_params.get_text(runtime::kLinkUdpHost), g_params.get_int(runtime::kLinkUdpPort));
    g_link.udp = &g_udp;
  }
  g_link.serial_fd = link_port.fd;
  return true;
}

// The console's output: to its port, at most 5 ms per write (a terminal that stopped reading
// must not stall the pipeline). On a port shared with the link the next frame starts with a 0x00,
// so a receiver drops this text as one bad block and decodes the frame after it.
class ConsoleOut final : public runtime::ConsoleWriter {
 public:
  int fd = -1;
  hal::LinkFanout* link = nullptr;  // set when the console shares the link's port
  void write(const char* s, size_t n) override {
    if (link != nullptr) link->serial_resync = true;
    if (fd >= 0) hal::write_all(fd, s, n, 5);
  }
};

class FileCalibStorage final : public runtime::CalibrationStorage {
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

// The loop's work: console bytes to the console, ticks to the runtime, state changes to the log.
class Service final : public hal::ServiceHandler {
 public:
  Service(runtime::Runtime& rt, runtime::Console& console, robot::RobotSession& session)
      : rt_(rt), console_(console), session_(session) {}
  void console_input(const char* data, size_t n) override { console_.feed(data, n); }
  void link_input(const uint8_t* data, size_t n) override { g_robot.frames(RobotLink::kSerialClient, data, n); }
  void tick(uint64_t now_us) override {
    rt_.tick(now_us);
    session_.tick(now_us);
    if (rt_.state() == last_state_ && rt_.results_sent() == last_results_) return;
    // log.level info (2) and up: state changes; debug (3): every result.
    if (g_params.get_int(runtime::kLogLevel) >= 2 && rt_.state() != last_state_)
      std::printf("state: %s\n", runtime::to_string(rt_.state()));
    if (g_params.get_int(runtime::kLogLevel) >= 3 && rt_.results_sent() != last_results_)
      std::printf("result: seq %u sent (tcp clients %d, serial drops %u)\n", unsigned(rt_.results_sent() - 1),
                  g_tcp.client_count(), unsigned(g_link.serial_drops));
    std::fflush(stdout);
    last_state_ = rt_.state();
    last_results_ = rt_.results_sent();
  }

 private:
  runtime::Runtime& rt_;
  runtime::Console& console_;
  robot::RobotSession& session_;
  runtime::RuntimeState last_state_ = runtime::RuntimeState::kIdle;
  uint32_t last_results_ = 0;
};

int fail(const std::string& err) {
  std::fprintf(stderr, "edgefused: %s\n", err.c_str());
  return 1;
}

// Runtime, calibration, ports and console around `pipeline`, served until a signal.
int serve(runtime::Pipeline& pipeline) {
  std::string err;
  static hal::CalibFileStore store(g_params.get_text(runtime::kCalibDir));
  static FileCalibStorage storage(store);
  static runtime::Runtime rt(pipeline, g_params, storage, g_publisher);
  static robot::RobotSession session(rt, pipeline, g_robot);
  rt.set_result_listener(&session);
  g_robot.session = &session;
  // The robot's flange poses feed the device pipeline's robot modes (both run on this thread).
  if (&pipeline == &g_devices) g_devices.set_flange_poses(&session);
  {
    // Calibration: the newest valid slot, a corrupt one reported.
    runtime::CalibrationData d;
    hal::CalibLoadReport rep;
    if (store.load(d, rep)) rt.set_calibration(d);
    std::printf("%s\n", rep.message.c_str());
  }
  hal::Port console_port, link_port;
  if (!open_ports(console_port, link_port, err)) return fail(err);
  const bool shared = std::string(g_params.get_text(runtime::kConsoleSerial)) == "link";
  static ConsoleOut console_out;
  console_out.fd = shared ? link_port.fd : console_port.fd;
  console_out.link = shared ? &g_link : nullptr;
  static const std::string banner = std::string("edgefused ") + kVersion;
  static runtime::Console console(rt, g_params, console_out, banner.c_str());
  console.set_echo(g_params.get_bool(runtime::kConsoleEcho));
  Service service(rt, console, session);
  hal::ServiceSources sources;
  sources.console_fd = console_port.fd;
  sources.link_fd = link_port.fd;
  sources.console_on_link = shared;
  sources.tcp = g_link.tcp;
  sources.text = g_params.get_bool(runtime::kRobotText) ? &g_text : nullptr;
  const int sig = hal::serve_until_signal(sources, service);
  g_devices.shutdown();
  std::printf("edgefused: stopped by %s after %u results\n", sig == SIGINT ? "SIGINT" : "SIGTERM",
              unsigned(rt.results_sent()));
  const robot::SessionCounters& rc = session.counters();
  std::printf("robot: %u requests (%u pose updates), %u bad, %u unknown, %u poses refused, %u replies\n",
              unsigned(rc.requests), unsigned(rc.pose_updates), unsigned(rc.bad_requests), unsigned(rc.unknown_commands),
              unsigned(rc.poses_refused), unsigned(rc.replies));
  std::fflush(stdout);
  g_tcp.close();
  g_text.close();
  g_udp.close();
  hal::close_port(console_port);
  hal::close_port(link_port);
  return 0;
}

}  // namespace

int run_edgefused(int argc, char** argv, runtime::Pipeline* pipeline) {
  CommandLine c;
  const int code = parse_command_line(argc, argv, c);
  if (code >= 0) return code;
  std::string err;
  if (!load_parameters(c, err) || !check_combinations(c.board, err)) return fail(err);
  std::printf("edgefused %s: board %s, config %s, space %lld^3, voxel %g m, truncation %g m\n", kVersion, c.board.c_str(),
              c.config.empty() ? "(defaults)" : c.config.c_str(), static_cast<long long>(g_params.get_int(runtime::kTsdfDim)),
              g_params.get_number(runtime::kTsdfVoxelM), g_params.get_number(runtime::kTsdfTruncM));
  if (c.check_only) {  // everything above reads files only; the devices, ports and files below are not touched
    std::string dir;
    if (hal::board_data_dir(dir, err)) std::printf("board data: %s\n", dir.c_str());
    std::printf("configuration OK\n");
    return 0;
  }
  if (pipeline == nullptr) {
    if (!start_device_pipeline(c.board, err)) return fail(err);
    pipeline = &g_devices;
  }
  return serve(*pipeline);
}

}  // namespace edgefuse::firmware
