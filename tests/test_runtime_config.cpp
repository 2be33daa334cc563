// Runtime configuration: the parameter table's defaults, range checks with messages that name key,
// value and allowed range, the TOML file (good, out of range, wrong type, unknown key, syntax
// error) and --set overrides.
#include <unistd.h>

#include <cstdio>
#include <string>

#include "edgefuse/hal/platform/config/config_toml.hpp"
#include "edgefuse/runtime/params.hpp"

#include <CppUTest/TestHarness.h>

using namespace edgefuse;
using namespace edgefuse::runtime;

namespace {

std::string write_temp(const char* text) {
  char path[] = "/tmp/edgefuse_cfg_XXXXXX";
  const int fd = mkstemp(path);
  CHECK(fd >= 0);
  const ssize_t n = ::write(fd, text, std::string(text).size());
  CHECK(n >= 0);
  ::close(fd);
  return path;
}

bool contains(const std::string& s, const char* part) { return s.find(part) != std::string::npos; }

}  // namespace

TEST_GROUP(RuntimeConfig){};

TEST(RuntimeConfig, DefaultsAreInRangeAndFindable) {
  ParamStore p;
  CHECK_EQUAL(5555, p.get_int(kLinkTcpPort));
  CHECK_EQUAL(115200, p.get_int(kLinkBaud));
  CHECK(p.get_bool(kConsoleEcho));
  STRCMP_EQUAL("pty", p.get_text(kLinkSerial));
  for (int i = 0; i < kParamCount; ++i) {
    CHECK_EQUAL(i, ParamStore::find(kParamDefs[i].key));
    char v[ParamStore::kTextCap], err[200];
    p.format(i, v, sizeof(v));
    ParamStore q;
    CHECK_TEXT(q.set(i, v, err, sizeof(err)), kParamDefs[i].key);  // format() output is accepted by set()
  }
  CHECK_EQUAL(-1, ParamStore::find("link.nope"));
}

TEST(RuntimeConfig, OutOfRangeNamesKeyValueAndRange) {
  ParamStore p;
  char err[200];
  CHECK_FALSE(p.set(kLinkTcpPort, "70000", err, sizeof(err)));
  STRCMP_EQUAL("link.tcp_port = 70000 is out of range [0, 65535]", err);
  CHECK_EQUAL(5555, p.get_int(kLinkTcpPort));  // unchanged
  CHECK_FALSE(p.set(kLinkTcpPort, "12x", err, sizeof(err)));
  CHECK(contains(err, "not an integer"));
  CHECK_FALSE(p.set(kLinkTcpPort, "1.5", err, sizeof(err)));
  CHECK_FALSE(p.set(kLocalizeMinScore, "nan", err, sizeof(err)));
  CHECK_FALSE(p.set(kLocalizeMinScore, "1.01", err, sizeof(err)));
  STRCMP_EQUAL("localize.min_score = 1.01 is out of range [0, 1]", err);
  CHECK_FALSE(p.set(kConsoleEcho, "maybe", err, sizeof(err)));
  CHECK(contains(err, "true|false"));
  CHECK(p.set(kLocalizeMinScore, "0.75", err, sizeof(err)));
  DOUBLES_EQUAL(0.75, p.get_number(kLocalizeMinScore), 1e-12);
  const std::string long_text(200, 'a');
  CHECK_FALSE(p.set(kCalibDir, long_text.c_str(), err, sizeof(err)));
}

TEST(RuntimeConfig, TomlFileSetsValues) {
  const std::string path = write_temp(
      "[link]\ntcp_port = 6000\nserial = \"/dev/ttyS1\"\nbaud = 921600\n"
      "[localize]\nmin_score = 0.6\nstill_period_s = 3\n[console]\necho = false\n");
  ParamStore p;
  std::string err;
  CHECK_TEXT(hal::load_config_toml(path, p, err), err.c_str());
  CHECK_EQUAL(6000, p.get_int(kLinkTcpPort));
  STRCMP_EQUAL("/dev/ttyS1", p.get_text(kLinkSerial));
  CHECK_EQUAL(921600, p.get_int(kLinkBaud));
  DOUBLES_EQUAL(0.6, p.get_number(kLocalizeMinScore), 1e-12);
  DOUBLES_EQUAL(3.0, p.get_number(kLocalizeStillPeriodS), 1e-12);
  CHECK_FALSE(p.get_bool(kConsoleEcho));
  ::unlink(path.c_str());
}

TEST(RuntimeConfig, BadTomlStopsWithAClearMessage) {
  struct Case {
    const char* text;
    const char* expect;
  };
  const Case cases[] = {
      {"[link]\ntcp_port = 70000\n", "link.tcp_port = 70000 is out of range [0, 65535]"},
      {"[link]\ntcp_port = \"5555\"\n", "wrong type"},
      {"[link]\nserial = 5\n", "wrong type"},
      {"[link]\ntcp_prot = 1\n", "unknown key 'link.tcp_prot'"},
      {"[link\ntcp_port = 1\n", "TOML syntax error"},
      {"[tsdf]\nvoxel_m = 0.5\n", "tsdf.voxel_m = 0.5 is out of range [0.0005, 0.05]"},
      {"[link]\nbaud = [1, 2]\n", "unsupported value type"},
  };
  for (const Case& c : cases) {
    const std::string path = write_temp(c.text);
    ParamStore p;
    std::string err;
    CHECK_FALSE(hal::load_config_toml(path, p, err));
    CHECK_TEXT(contains(err, c.expect), err.c_str());
    CHECK_TEXT(contains(err, path.c_str()), err.c_str());  // names the file
    ::unlink(path.c_str());
  }
  ParamStore p;
  std::string err;
  CHECK_FALSE(hal::load_config_toml("/nonexistent/edgefused.toml", p, err));
  CHECK(contains(err, "/nonexistent/edgefused.toml"));
}

// All or nothing (found by tests/fuzz): a file refused at its second value must not leave its
// first value behind, and a non-ASCII character outside a comment is refused (toml_guard.hpp).
TEST(RuntimeConfig, ARefusedFileChangesNoValue) {
  ParamStore p;
  std::string err;
  const std::string path = write_temp("[link]\nbaud = 9600\ntcp_port = 99999999\n");
  CHECK_FALSE(hal::load_config_toml(path, p, err));
  CHECK_TEXT(contains(err, "tcp_port"), err.c_str());
  CHECK_EQUAL(115200, p.get_int(kLinkBaud));
  CHECK_EQUAL(5555, p.get_int(kLinkTcpPort));
  const std::string utf8 = write_temp("# Greifer f\xc3\xbcr Kiste 3\n[link]\nbaud = 9600\nserial = \"/dev/tty\xc3\xa4\"\n");
  CHECK_FALSE(hal::load_config_toml(utf8, p, err));
  CHECK_TEXT(contains(err, ":4: a non-ASCII character outside a comment"), err.c_str());
  CHECK_EQUAL(115200, p.get_int(kLinkBaud));
  std::remove(path.c_str());
  std::remove(utf8.c_str());
}

// host-sim is the simulator's board: its file asks for the backend's truth explicitly (known
// poses, simulator truth for the robot pose and the mountings); every other key is the default.
TEST(RuntimeConfig, TheShippedHostSimConfigLoadsAndEqualsTheDefaultsButTheSimulatorTruth) {
  ParamStore p;
  std::string err;
  CHECK_TEXT(hal::load_config_toml(std::string(EDGEFUSE_SOURCE_DIR) + "/board/host-sim/edgefused.toml", p, err),
             err.c_str());
  ParamStore defaults;
  STRCMP_EQUAL("icp", defaults.get_text(kTrackingPoses));
  CHECK_FALSE(defaults.get_bool(kTrackingSimTruth));
  STRCMP_EQUAL("known", p.get_text(kTrackingPoses));
  CHECK_TRUE(p.get_bool(kTrackingSimTruth));
  char a[ParamStore::kTextCap], b[ParamStore::kTextCap];
  for (int i = 0; i < kParamCount; ++i) {
    if (i == kTrackingPoses || i == kTrackingSimTruth) continue;
    p.format(i, a, sizeof(a));
    defaults.format(i, b, sizeof(b));
    STRCMP_EQUAL_TEXT(b, a, kParamDefs[i].key);
  }
}

TEST(RuntimeConfig, SetOverrides) {
  ParamStore p;
  std::string err;
  CHECK(hal::apply_override("link.tcp_port=7001", p, err));
  CHECK_EQUAL(7001, p.get_int(kLinkTcpPort));
  CHECK(hal::apply_override("sensors.replay=/data/bin_rig_a", p, err));
  STRCMP_EQUAL("/data/bin_rig_a", p.get_text(kSensorsReplay));
  CHECK(hal::apply_override("link.udp_host=", p, err));  // empty string allowed
  CHECK_FALSE(hal::apply_override("link.tcp_port=-1", p, err));
  CHECK(contains(err, "link.tcp_port = -1 is out of range [0, 65535]"));
  CHECK_FALSE(hal::apply_override("link.tcp_port", p, err));
  CHECK(contains(err, "KEY=VALUE"));
  CHECK_FALSE(hal::apply_override("nope=1", p, err));
  CHECK(contains(err, "unknown key 'nope'"));
}
