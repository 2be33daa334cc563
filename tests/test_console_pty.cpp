// The serial console driven over a pseudo-terminal pair with a scripted session, as picocom would
// drive it: the console reads the controller side, the test types on the terminal side (opened
// raw 8N1 like a serial port). Every reply must end in OK or ERR <code>; garbage, over-long lines,
// wrong arguments and random bytes give ERR and the console keeps answering.
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "edgefuse/hal/platform/serial_sockets/serial_port.hpp"
#include "edgefuse/runtime/console.hpp"

#include <CppUTest/TestHarness.h>

using namespace edgefuse;
using namespace edgefuse::runtime;

namespace {

// Records what the console asked for.
class FakeService : public ConsoleService {
 public:
  std::vector<std::string> calls;
  CmdResult status(ConsoleWriter& out) override {
    out.line("state MAPPING fps 29.5 frames 120 drops 0 tracking OK");
    out.line("device xtion ok");
    return rec("status");
  }
  CmdResult calib_fuse(const char* from, const char* to, ConsoleWriter&) override {
    return rec(std::string("calib_fuse ") + from + " " + to);
  }
  CmdResult calib_show(ConsoleWriter& out) override {
    out.line("xtion -> tof: 0.1 0 0 0 0 0 1");
    return rec("calib_show");
  }
  CmdResult calib_set(const char* sensor, const float tq[7]) override {
    char b[128];
    std::snprintf(b, sizeof(b), "calib_set %s %.3f %.3f %.3f %.3f %.3f %.3f %.3f", sensor, double(tq[0]),
                  double(tq[1]), double(tq[2]), double(tq[3]), double(tq[4]), double(tq[5]), double(tq[6]));
    if (!std::strcmp(sensor, "nosuch")) return CmdResult::error(ConsoleError::kNotFound, "no sensor 'nosuch'");
    return rec(b);
  }
  CmdResult calib_intrinsics(const char* sensor, const float k[4]) override {
    char b[128];
    std::snprintf(b, sizeof(b), "calib_intrinsics %s %.1f %.1f %.1f %.1f", sensor, double(k[0]), double(k[1]),
                  double(k[2]), double(k[3]));
    return rec(b);
  }
  CmdResult calib_save() override { return rec("calib_save"); }
  CmdResult calib_load() override { return rec("calib_load"); }
  CmdResult calib_reset() override { return rec("calib_reset"); }
  CmdResult scan(bool start) override { return rec(start ? "scan start" : "scan stop"); }
  CmdResult map_reset() override { return rec("map_reset"); }
  CmdResult localize() override {
    calls.push_back("localize");
    return CmdResult::error(ConsoleError::kWrongState, "no map yet (scan start first)");
  }
  CmdResult model_list(ConsoleWriter& out) override {
    out.line("1 bracket");
    return rec("model_list");
  }
  CmdResult log_level(int level) override { return rec("log " + std::to_string(level)); }
  CmdResult param_changed(int id) override { return rec(std::string("param ") + kParamDefs[id].key); }

 private:
  CmdResult rec(const std::string& s) {
    calls.push_back(s);
    return CmdResult::ok();
  }
};

class FdWriter : public ConsoleWriter {
 public:
  explicit FdWriter(int fd) : fd_(fd) {}
  void write(const char* s, size_t n) override { hal::write_all(fd_, s, n, 1000); }

 private:
  int fd_;
};

struct Session {
  hal::PtyPair pty;
  int term = -1;  // what picocom would hold
  FakeService service;
  ParamStore params;
  FdWriter* writer = nullptr;
  Console* console = nullptr;
  std::string pending;  // terminal output received while typing

  Session() {
    std::string err;
    CHECK_TEXT(hal::pty_open(pty, err), err.c_str());
    term = hal::serial_open(pty.terminal_name, 115200, err);
    CHECK_TEXT(term >= 0, err.c_str());
    writer = new FdWriter(pty.controller);
    console = new Console(service, params, *writer, "edgefused 0.1.0 (test)");
  }
  ~Session() {
    delete console;
    delete writer;
    ::close(term);
    hal::pty_close(pty);
  }

  // Moves bytes console-side until the terminal has received `replies` final lines (OK / ERR).
  std::string pump(int replies) {
    std::string got;
    got.swap(pending);
    char buf[4096];
    for (int spins = 0; spins < 2000; ++spins) {  // up to ~10 s on a loaded machine
      pollfd p[2] = {{pty.controller, POLLIN, 0}, {term, POLLIN, 0}};
      ::poll(p, 2, 5);
      ssize_t n = ::read(pty.controller, buf, sizeof(buf));
      if (n > 0) console->feed(buf, size_t(n));
      while ((n = ::read(term, buf, sizeof(buf))) > 0) got.append(buf, size_t(n));
      if (count_replies(got) >= replies) return got;
    }
    return got;
  }
  static int count_replies(const std::string& s) {
    int k = 0;
    size_t at = 0;
    while (at < s.size()) {
      const size_t eol = s.find("\r\n", at);
      if (eol == std::string::npos) break;
      const std::string line = s.substr(at, eol - at);
      if (line == "OK" || line.rfind("ERR ", 0) == 0) ++k;
      at = eol + 2;
    }
    return k;
  }
  // Types `s`, moving bytes through the console meanwhile (the pty buffer holds only a few KiB).
  void type(const std::string& s) {
    size_t at = 0;
    char buf[4096];
    for (int spins = 0; at < s.size() && spins < 10000; ++spins) {
      const ssize_t w = ::write(term, s.data() + at, std::min<size_t>(512, s.size() - at));
      if (w > 0) at += size_t(w);
      ssize_t n = ::read(pty.controller, buf, sizeof(buf));
      if (n > 0) console->feed(buf, size_t(n));
      while ((n = ::read(term, buf, sizeof(buf))) > 0) pending.append(buf, size_t(n));
      if (w <= 0) ::usleep(1000);
    }
    CHECK_EQUAL(s.size(), at);
  }
  //! Types a command with a CR (as terminal programs send Enter) and returns the whole reply.
  std::string cmd(const std::string& line) {
    type(line + "\r");
    return pump(1);
  }
};

bool ends_ok(const std::string& r) { return r.size() >= 4 && r.compare(r.size() - 4, 4, "OK\r\n") == 0; }
bool ends_err(const std::string& r, int code) {
  const std::string want = "ERR " + std::to_string(code) + " ";
  const size_t last = r.rfind("\r\n", r.size() - 3);
  const std::string line = r.substr(last == std::string::npos ? 0 : last + 2);
  return line.rfind(want, 0) == 0;
}

}  // namespace

TEST_GROUP(ConsolePty){};

TEST(ConsolePty, ScriptedSession) {
  Session s;
  std::string r = s.cmd("help");
  CHECK(ends_ok(r));
  CHECK(r.find("calib set <sensor> <tx ty tz qx qy qz qw>") != std::string::npos);
  CHECK(r.find("param set <name> <value>") != std::string::npos);
  r = s.cmd("version");
  STRCMP_EQUAL("edgefused 0.1.0 (test)\r\nOK\r\n", r.c_str());
  r = s.cmd("status");
  CHECK(ends_ok(r) && r.find("state MAPPING") != std::string::npos);
  CHECK(ends_ok(s.cmd("calib set tof 0.1 0 0.02 0 0 0 1")));
  CHECK(ends_ok(s.cmd("calib   fuse   xtion tof")));  // extra blanks are fine
  CHECK(ends_ok(s.cmd("calib show")));
  CHECK(ends_ok(s.cmd("calib intrinsics tof 211.5 211 160 120.5")));
  CHECK(ends_ok(s.cmd("calib save")));
  CHECK(ends_ok(s.cmd("calib load")));
  CHECK(ends_ok(s.cmd("calib reset")));
  CHECK(ends_ok(s.cmd("scan start")));
  CHECK(ends_ok(s.cmd("scan stop")));
  CHECK(ends_ok(s.cmd("map reset")));
  CHECK(ends_err(s.cmd("localize"), 5));  // the service's own error passes through
  CHECK(ends_ok(s.cmd("model list")));
  CHECK(ends_ok(s.cmd("log debug")));
  CHECK_EQUAL(3, s.params.get_int(kLogLevel));
  r = s.cmd("param get link.tcp_port");
  CHECK(ends_ok(r) && r.find("link.tcp_port = 5555  [0, 65535]") != std::string::npos);
  r = s.cmd("param set localize.min_score 0.7");
  CHECK(ends_ok(r));
  DOUBLES_EQUAL(0.7, s.params.get_number(kLocalizeMinScore), 1e-12);
  CHECK(ends_ok(s.cmd("param get")));

  const std::vector<std::string> want = {
      "status", "calib_set tof 0.100 0.000 0.020 0.000 0.000 0.000 1.000", "calib_fuse xtion tof", "calib_show",
      "calib_intrinsics tof 211.5 211.0 160.0 120.5", "calib_save", "calib_load", "calib_reset", "scan start", "scan stop", "map_reset", "localize", "model_list",
      "log 3", "param localize.min_score"};
  CHECK_EQUAL(want.size(), s.service.calls.size());
  for (size_t i = 0; i < want.size(); ++i) STRCMP_EQUAL(want[i].c_str(), s.service.calls[i].c_str());
}

TEST(ConsolePty, WrongArgumentsGiveErr) {
  Session s;
  CHECK(ends_err(s.cmd("frobnicate"), 1));
  std::string usage = s.cmd("calib");
  CHECK(ends_err(usage, 2));
  CHECK_TEXT(usage.find("usage: calib <fuse|show|set|intrinsics|save|load|reset>") != std::string::npos, usage.c_str());
  CHECK(ends_err(s.cmd("calib explode"), 2));
  CHECK(ends_err(s.cmd("calib set tof 1 2 3"), 2));
  CHECK(ends_err(s.cmd("calib set tof a b c d e f g"), 2));
  CHECK(ends_err(s.cmd("calib set tof 0 0 0 0 0 0 2"), 4));   // not a unit quaternion
  CHECK(ends_err(s.cmd("calib set tof 99 0 0 0 0 0 1"), 4));  // 99 m
  CHECK(ends_err(s.cmd("calib set nosuch 0 0 0 0 0 0 1"), 7));
  CHECK(ends_err(s.cmd("calib fuse xtion xtion"), 2));
  CHECK(ends_err(s.cmd("calib intrinsics tof 0 211 160 120"), 4));
  CHECK(ends_err(s.cmd("calib intrinsics tof 211 211 160"), 2));
  CHECK(ends_err(s.cmd("scan sideways"), 2));
  CHECK(ends_err(s.cmd("version extra"), 2));
  CHECK(ends_err(s.cmd("log loud"), 2));
  std::string r = s.cmd("param set localize.min_score 2");
  CHECK(ends_err(r, 4));
  CHECK(r.find("localize.min_score = 2 is out of range [0, 1]") != std::string::npos);
  CHECK(ends_err(s.cmd("param set link.tcp_port 6000"), 5));  // needs a restart
  CHECK(ends_err(s.cmd("param get no.such"), 7));
  CHECK(ends_err(s.cmd("param set localize.min_score"), 2));
  CHECK(ends_err(s.cmd("a b c d e f g h i j k l m"), 2));  // too many words
  CHECK_EQUAL(0u, s.service.calls.size());  // none of them reached the service
}

TEST(ConsolePty, GarbageAndOverlongLinesGiveErrAndTheConsoleRecovers) {
  Session s;
  CHECK(ends_err(s.cmd(std::string("\x01\x02hello\x1b[A")), 9));
  CHECK(ends_err(s.cmd(std::string(5000, 'x')), 3));
  CHECK(ends_ok(s.cmd("version")));
  // CR LF, LF and CR all end a line, and an empty line gets no reply.
  s.type("version\r\nversion\nversion\r\r\n");
  const std::string r = s.pump(3);
  CHECK_EQUAL(3, Session::count_replies(r));
  // Backspace edits the line.
  CHECK(ends_ok(s.cmd("versiom\x7f" "n")));
  // Random bytes: each completed line gets exactly one reply, nothing hangs, and afterwards the
  // console still answers.
  // Lines of 1..300 random bytes (no line ends, no Ctrl-C/Ctrl-U, which drop a line on purpose).
  std::mt19937 rng(1234);
  std::string noise;
  const int lines = 150;
  for (int l = 0; l < lines; ++l) {
    const int len = 1 + int(rng() % 300);
    for (int i = 0; i < len; ++i) {
      char c = char(rng() & 0xFF);
      if (c == '\r' || c == '\n' || c == 0x03 || c == 0x15) c = '\x01';
      noise += c;
    }
    noise += "\n";
  }
  s.type(noise);
  const std::string replies = s.pump(lines);
  // Each line is answered exactly once (a line of printable bytes only gets ERR 1 or ERR 3, one
  // with a control byte ERR 9); lines made of backspaces only would be empty, so allow for those.
  const int n = Session::count_replies(replies);
  CHECK_TEXT(n <= lines && n >= lines - 2, (std::to_string(n) + " of " + std::to_string(lines)).c_str());
  CHECK(ends_ok(s.cmd("\x03version")));  // Ctrl-C drops a half-typed line
}

TEST(ConsolePty, EchoForTerminalPrograms) {
  Session s;
  s.console->set_echo(true);
  const std::string r = s.cmd("version");
  STRCMP_EQUAL("version\r\nedgefused 0.1.0 (test)\r\nOK\r\n", r.c_str());
}
