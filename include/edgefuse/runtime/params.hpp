// Runtime parameters of edgefused: one static table (name, type, allowed range, default, whether it
// may change while running) shared by the TOML configuration, `--set key=value` and the console's
// `param get|set`. Every value is range-checked on the way in; an error names key, value and the
// allowed range. No heap, no exceptions: values live in a fixed array.
#pragma once

#include <cstddef>

namespace edgefuse::runtime {

enum class ParamType { kInt, kFloat, kBool, kString };

struct ParamDef {
  const char* key;      //!< "section.name", as in the TOML file
  ParamType type;
  double min;           //!< numbers: smallest allowed value; strings: unused
  double max;           //!< numbers: largest allowed value; strings: longest length
  const char* fallback; //!< default, as text (parsed and checked like any input)
  bool live;            //!< may be changed by the console while running
  const char* help;
};

constexpr size_t kParamTextMax = 127;

//! Identifiers of the parameters (indices into kParamDefs).
enum ParamId : int {
  kLinkSerial = 0,
  kLinkBaud,
  kLinkTcp,
  kLinkTcpBind,
  kLinkTcpPort,
  kLinkUdpHost,
  kLinkUdpPort,
  kLinkHeartbeatMs,
  kConsoleSerial,
  kConsoleBaud,
  kConsoleEcho,
  kLogLevel,
  kLocalizeStillPeriodS,
  kLocalizeMinScore,
  kReportRepeat,
  kCalibDir,
  kSensorsReplay,
  kTsdfDim,
  kTsdfVoxelM,
  kTsdfTruncM,
  // edgefused's pipeline: frame source, models, filters, tracking
  kLocalizeModels,
  kFiltersBilateral,
  kTrackingPoses,
  kTrackingPushEveryFrame,
  kTrackingSimTruth,
  // edgefused: which cameras feed the map
  kSensorsFuse,
  kSensorsReplaySpeed,
  // edgefused: the robot's text profile
  kRobotText,
  kRobotTextPort,
  kRobotUnits,
  kRobotRotation,
  kRobotLatencyUs,
  // edgefused: the sim rig's motion
  kSensorsSimPath,
  kParamCount
};

//! The table, in ParamId order.
extern const ParamDef kParamDefs[kParamCount];

//! One value: numbers and booleans in `number`, strings in `text`.
struct ParamValue {
  double number = 0;
  char text[kParamTextMax + 1] = {};
};

class ParamStore {
 public:
  static constexpr size_t kTextCap = kParamTextMax + 1;  //!< buffer size that holds any value

  //! Every parameter at its default.
  ParamStore();

  //! Index of a key, or -1.
  //! \param key "section.name"
  static int find(const char* key);

  //! Parses and range-checks `text` and stores it.
  //! \param id    the parameter
  //! \param text  the value as written in TOML/--set/console ("115200", "0.5", "true", "/dev/ttyS1")
  //! \param err   on failure: "KEY = VALUE is out of range [MIN, MAX]" or "... is not a number"
  //! \param err_cap capacity of err
  bool set(int id, const char* text, char* err, size_t err_cap);

  //! Writes the value as text (the form set() accepts).
  void format(int id, char* out, size_t cap) const;
  //! Writes the allowed range as text ("[1, 65535]", "true|false", "text up to 127 characters").
  static void format_range(int id, char* out, size_t cap);

  int get_int(int id) const { return static_cast<int>(values_[id].number); }
  double get_number(int id) const { return values_[id].number; }
  bool get_bool(int id) const { return values_[id].number != 0; }
  const char* get_text(int id) const { return values_[id].text; }

 private:
  ParamValue values_[kParamCount];
};

}  // namespace edgefuse::runtime
