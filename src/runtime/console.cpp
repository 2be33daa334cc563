#include "edgefuse/runtime/console.hpp"

#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace edgefuse::runtime {

void ConsoleWriter::line(const char* fmt, ...) {
  char buf[258];
  va_list ap;
  va_start(ap, fmt);
  int n = std::vsnprintf(buf, 256, fmt, ap);
  va_end(ap);
  if (n < 0) n = 0;
  if (n > 255) n = 255;
  buf[n++] = '\r';  // CR LF: terminal programs in raw mode do not map LF
  buf[n++] = '\n';
  write(buf, size_t(n));
}

namespace {

using Handler = CmdResult (*)(Console& c, ConsoleService& s, ParamStore& p, ConsoleWriter& out, const char* version,
                              int argc, char** argv);

struct Command {
  const char* name;
  const char* sub;  // second word, or nullptr
  int min_args;     // arguments after the name (and sub)
  int max_args;
  Handler run;
  const char* usage;
};

bool parse_float(const char* s, float& out) {
  char* end = nullptr;
  const double v = std::strtod(s, &end);
  if (end == s || *end != '\0' || !std::isfinite(v)) return false;
  out = float(v);
  return true;
}

CmdResult cmd_help(Console&, ConsoleService&, ParamStore&, ConsoleWriter& out, const char*, int, char**);

CmdResult cmd_version(Console&, ConsoleService&, ParamStore&, ConsoleWriter& out, const char* version, int, char**) {
  out.line("%s", version);
  return CmdResult::ok();
}
CmdResult cmd_status(Console&, ConsoleService& s, ParamStore&, ConsoleWriter& out, const char*, int, char**) {
  return s.status(out);
}
CmdResult cmd_calib_fuse(Console&, ConsoleService& s, ParamStore&, ConsoleWriter& out, const char*, int,
                         char** argv) {
  if (!std::strcmp(argv[0], argv[1]))
    return CmdResult::error(ConsoleError::kBadArguments, "calib fuse needs two different sensors");
  return s.calib_fuse(argv[0], argv[1], out);
}
CmdResult cmd_calib_show(Console&, ConsoleService& s, ParamStore&, ConsoleWriter& out, const char*, int, char**) {
  return s.calib_show(out);
}
CmdResult cmd_calib_set(Console&, ConsoleService& s, ParamStore&, ConsoleWriter&, const char*, int, char** argv) {
  float tq[7];
  for (int i = 0; i < 7; ++i)
    if (!parse_float(argv[1 + i], tq[i]))
      return CmdResult::error(ConsoleError::kBadArguments, "tx ty tz qx qy qz qw must be numbers");
  for (int i = 0; i < 3; ++i)
    if (std::fabs(tq[i]) > 10.0f)
      return CmdResult::error(ConsoleError::kOutOfRange, "translation beyond 10 m");
  const float qn = std::sqrt(tq[3] * tq[3] + tq[4] * tq[4] + tq[5] * tq[5] + tq[6] * tq[6]);
  if (std::fabs(qn - 1.0f) > 1e-3f)
    return CmdResult::error(ConsoleError::kOutOfRange, "quaternion is not unit length (|q| - 1 > 1e-3)");
  return s.calib_set(argv[0], tq);
}
CmdResult cmd_calib_intrinsics(Console&, ConsoleService& s, ParamStore&, ConsoleWriter&, const char*, int,
                               char** argv) {
  float k[4];
  for (int i = 0; i < 4; ++i)
    if (!parse_float(argv[1 + i], k[i]))
      return CmdResult::error(ConsoleError::kBadArguments, "fx fy cx cy must be numbers");
  // Focal lengths and principal point of any sensor here lie well inside 1..20000 pixels.
  for (int i = 0; i < 4; ++i)
    if (k[i] < (i < 2 ? 1.0f : 0.0f) || k[i] > 20000.0f)
      return CmdResult::error(ConsoleError::kOutOfRange, "fx fy in [1, 20000], cx cy in [0, 20000] pixels");
  return s.calib_intrinsics(argv[0], k);
}
CmdResult cmd_calib_save(Console&, ConsoleService& s, ParamStore&, ConsoleWriter&, const char*, int, char**) {
  return s.calib_save();
}
CmdResult cmd_calib_load(Console&, ConsoleService& s, ParamStore&, ConsoleWriter&, const char*, int, char**) {
  return s.calib_load();
}
CmdResult cmd_calib_reset(Console&, ConsoleService& s, ParamStore&, ConsoleWriter&, const char*, int, char**) {
  return s.calib_reset();
}
CmdResult cmd_scan_start(Console&, ConsoleService& s, ParamStore&, ConsoleWriter&, const char*, int, char**) {
  return s.scan(true);
}
CmdResult cmd_scan_stop(Console&, ConsoleService& s, ParamStore&, ConsoleWriter&, const char*, int, char**) {
  return s.scan(false);
}
CmdResult cmd_map_reset(Console&, ConsoleService& s, ParamStore&, ConsoleWriter&, const char*, int, char**) {
  return s.map_reset();
}
CmdResult cmd_localize(Console&, ConsoleService& s, ParamStore&, ConsoleWriter&, const char*, int, char**) {
  return s.localize();
}
CmdResult cmd_model_list(Console&, ConsoleService& s, ParamStore&, ConsoleWriter& out, const char*, int, char**) {
  return s.model_list(out);
}
CmdResult cmd_param_get(Console&, ConsoleService&, ParamStore& p, ConsoleWriter& out, const char*, int argc,
                        char** argv) {
  char value[ParamStore::kTextCap], range[48];
  if (argc == 0) {  // all of them
    for (int i = 0; i < kParamCount; ++i) {
      p.format(i, value, sizeof(value));
      ParamStore::format_range(i, range, sizeof(range));
      out.line("%s = %s  %s%s", kParamDefs[i].key, value, range, kParamDefs[i].live ? "" : " (restart)");
    }
    return CmdResult::ok();
  }
  const int id = ParamStore::find(argv[0]);
  if (id < 0) return CmdResult::error(ConsoleError::kNotFound, "no such parameter (param get lists them)");
  p.format(id, value, sizeof(value));
  ParamStore::format_range(id, range, sizeof(range));
  out.line("%s = %s  %s", kParamDefs[id].key, value, range);
  return CmdResult::ok();
}
CmdResult cmd_param_set(Console&, ConsoleService& s, ParamStore& p, ConsoleWriter& out, const char*, int,
                        char** argv) {
  const int id = ParamStore::find(argv[0]);
  if (id < 0) return CmdResult::error(ConsoleError::kNotFound, "no such parameter (param get lists them)");
  if (!kParamDefs[id].live)
    return CmdResult::error(ConsoleError::kWrongState, "fixed while running: set it in the config and restart");
  static char err[160];  // the reply's message outlives this call
  if (!p.set(id, argv[1], err, sizeof(err))) return CmdResult::error(ConsoleError::kOutOfRange, err);
  char value[ParamStore::kTextCap];
  p.format(id, value, sizeof(value));
  out.line("%s = %s", kParamDefs[id].key, value);
  return s.param_changed(id);
}
CmdResult cmd_log(Console&, ConsoleService& s, ParamStore& p, ConsoleWriter&, const char*, int, char** argv) {
  static const char* const kNames[] = {"error", "warn", "info", "debug", "trace"};
  int level = -1;
  for (int i = 0; i < 5; ++i)
    if (!std::strcmp(argv[0], kNames[i]) || (argv[0][0] == char('0' + i) && argv[0][1] == '\0')) level = i;
  if (level < 0) return CmdResult::error(ConsoleError::kBadArguments, "level is error|warn|info|debug|trace or 0..4");
  char text[2] = {char('0' + level), '\0'};
  char err[96];
  p.set(kLogLevel, text, err, sizeof(err));
  return s.log_level(level);
}

const Command kCommands[] = {
    {"help", nullptr, 0, 0, cmd_help, "help"},
    {"version", nullptr, 0, 0, cmd_version, "version"},
    {"status", nullptr, 0, 0, cmd_status, "status"},
    {"calib", "fuse", 2, 2, cmd_calib_fuse, "calib fuse <from> <to>"},
    {"calib", "show", 0, 0, cmd_calib_show, "calib show"},
    {"calib", "set", 8, 8, cmd_calib_set, "calib set <sensor> <tx ty tz qx qy qz qw>"},
    {"calib", "intrinsics", 5, 5, cmd_calib_intrinsics, "calib intrinsics <sensor> <fx fy cx cy>"},
    {"calib", "save", 0, 0, cmd_calib_save, "calib save"},
    {"calib", "load", 0, 0, cmd_calib_load, "calib load"},
    {"calib", "reset", 0, 0, cmd_calib_reset, "calib reset"},
    {"scan", "start", 0, 0, cmd_scan_start, "scan start"},
    {"scan", "stop", 0, 0, cmd_scan_stop, "scan stop"},
    {"map", "reset", 0, 0, cmd_map_reset, "map reset"},
    {"localize", nullptr, 0, 0, cmd_localize, "localize"},
    {"model", "list", 0, 0, cmd_model_list, "model list"},
    {"param", "get", 0, 1, cmd_param_get, "param get [<name>]"},
    {"param", "set", 2, 2, cmd_param_set, "param set <name> <value>"},
    {"log", nullptr, 1, 1, cmd_log, "log <error|warn|info|debug|trace>"},
};

CmdResult cmd_help(Console&, ConsoleService&, ParamStore&, ConsoleWriter& out, const char*, int, char**) {
  for (const Command& c : kCommands) out.line("  %s", c.usage);
  return CmdResult::ok();
}

}  // namespace

void Console::feed(const char* data, size_t n) {
  for (size_t i = 0; i < n; ++i) {
    const char c = data[i];
    if (c == '\r' || c == '\n') {
      // CR LF, LF CR and lone CR or LF all end one line.
      const bool pair = (c == '\n' && last_cr_);
      last_cr_ = (c == '\r');
      if (pair) continue;
      if (echo_) out_.write("\r\n", 2);
      end_of_line();
      continue;
    }
    last_cr_ = false;
    if (c == 0x08 || c == 0x7F) {  // backspace / delete
      if (len_ > 0 && !overflow_) {
        --len_;
        if (echo_) out_.write("\b \b", 3);
      }
      continue;
    }
    if (c == 0x03 || c == 0x15) {  // Ctrl-C / Ctrl-U: drop the line
      len_ = 0;
      overflow_ = bad_char_ = false;
      if (echo_) out_.write("^C\r\n", 4);
      continue;
    }
    const unsigned char u = static_cast<unsigned char>(c);
    if (u < 0x20 || u > 0x7E) {
      bad_char_ = true;  // reported when the line ends; the rest of the line is still consumed
      continue;
    }
    if (len_ >= kLineMax) {
      overflow_ = true;
      continue;
    }
    line_[len_++] = c;
    if (echo_) out_.write(&c, 1);
  }
}

void Console::end_of_line() {
  line_[len_] = '\0';
  const size_t len = len_;
  len_ = 0;
  if (overflow_ || bad_char_) {
    const bool overflow = overflow_;
    overflow_ = bad_char_ = false;
    if (overflow)
      reply(CmdResult::error(ConsoleError::kLineTooLong, "line too long (at most 128 characters)"));
    else
      reply(CmdResult::error(ConsoleError::kBadCharacter, "line holds non-printable characters"));
    return;
  }
  if (len == 0) return;  // an empty line: nothing to answer (terminals send them freely)
  execute(line_);
}

void Console::execute(char* line) {
  char* argv[kArgsMax + 1];
  int argc = 0;
  for (char* p = line; *p;) {
    while (*p == ' ' || *p == '\t') *p++ = '\0';
    if (!*p) break;
    if (argc == kArgsMax) {
      reply(CmdResult::error(ConsoleError::kBadArguments, "too many arguments"));
      return;
    }
    argv[argc++] = p;
    while (*p && *p != ' ' && *p != '\t') ++p;
  }
  if (argc == 0) return;
  reply(dispatch(argc, argv));
}

CmdResult Console::dispatch(int argc, char** argv) {
  bool name_known = false;
  for (const Command& c : kCommands) {
    if (std::strcmp(c.name, argv[0]) != 0) continue;
    name_known = true;
    int first = 1;
    if (c.sub != nullptr) {
      if (argc < 2 || std::strcmp(c.sub, argv[1]) != 0) continue;
      first = 2;
    }
    const int nargs = argc - first;
    if (nargs < c.min_args || nargs > c.max_args) {
      static char msg[96];
      std::snprintf(msg, sizeof(msg), "usage: %s", c.usage);
      return CmdResult::error(ConsoleError::kBadArguments, msg);
    }
    return c.run(*this, service_, params_, out_, version_, nargs, argv + first);
  }
  if (name_known) {  // "calib" alone or with an unknown second word: list the second words
    static char msg[128];
    int n = std::snprintf(msg, sizeof(msg), "usage: %s <", argv[0]);
    const char* sep = "";
    for (const Command& c : kCommands)
      if (!std::strcmp(c.name, argv[0]) && n > 0 && n < int(sizeof(msg))) {
        n += std::snprintf(msg + n, sizeof(msg) - size_t(n), "%s%s", sep, c.sub);
        sep = "|";
      }
    if (n > 0 && n < int(sizeof(msg)) - 1) std::snprintf(msg + n, sizeof(msg) - size_t(n), ">");
    return CmdResult::error(ConsoleError::kBadArguments, msg);
  }
  return CmdResult::error(ConsoleError::kUnknownCommand, "unknown command (try help)");
}

void Console::reply(const CmdResult& r) {
  if (r.code == ConsoleError::kOk)
    out_.line("OK");
  else
    out_.line("ERR %d %s", static_cast<int>(r.code), r.message);
}

}  // namespace edgefuse::runtime
