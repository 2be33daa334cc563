#include "edgefuse/runtime/params.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace edgefuse::runtime {

// Ranges say what the hardware and the method allow, not what is typical:
// - baud: the termios rates from 1200 to 4 Mbit/s (the rate itself is checked again when opening);
// - heartbeat: at least 10 per second is pointless load, less than one a minute hides a dead link;
// - voxel / truncation: 0.5 mm is below any sensor's noise here; 5 cm cannot resolve a part.
const ParamDef kParamDefs[kParamCount] = {
    {"link.serial", ParamType::kString, 0, kParamTextMax, "pty", false,
     "pose link serial port: a device, 'pty' (host-sim: a pseudo-terminal) or '' (off)"},
    {"link.baud", ParamType::kInt, 1200, 4000000, "115200", false, "pose link serial bit rate (8N1)"},
    {"link.tcp", ParamType::kBool, 0, 1, "true", false, "TCP server on/off"},
    {"link.tcp_bind", ParamType::kString, 0, kParamTextMax, "0.0.0.0", false, "TCP server address"},
    {"link.tcp_port", ParamType::kInt, 0, 65535, "5555", false, "TCP server port (0: any free port, printed)"},
    {"link.udp_host", ParamType::kString, 0, kParamTextMax, "", false, "UDP destination host ('' off)"},
    {"link.udp_port", ParamType::kInt, 1, 65535, "5556", false, "UDP destination port"},
    {"link.heartbeat_ms", ParamType::kInt, 100, 60000, "1000", true, "heartbeat period"},
    {"console.serial", ParamType::kString, 0, kParamTextMax, "pty", false,
     "console serial port: a device, 'pty', 'link' (share the link's port) or '' (off)"},
    {"console.baud", ParamType::kInt, 1200, 4000000, "115200", false, "console bit rate (8N1)"},
    {"console.echo", ParamType::kBool, 0, 1, "true", true, "echo typed characters (for picocom/screen)"},
    {"log.level", ParamType::kInt, 0, 4, "2", true, "0 error, 1 warn, 2 info, 3 debug, 4 trace"},
    {"localize.still_period_s", ParamType::kFloat, 0, 600, "0", true,
     "localise after the rig was still this long (0: only on command)"},
    {"localize.min_score", ParamType::kFloat, 0, 1, "0.5", true, "drop objects scoring less"},
    {"report.repeat", ParamType::kInt, 1, 100, "1", true, "times each result is sent"},
    {"calib.dir", ParamType::kString, 0, kParamTextMax, "edgefused-state", false,
     "folder of the calibration slots"},
    {"sensors.replay", ParamType::kString, 0, kParamTextMax, "", false,
     "host-sim: replay this rig set instead of the built-in scene"},
    {"tsdf.dim", ParamType::kInt, 8, 4096, "256", false,
     "voxels per axis of the space, a multiple of 8 up to the board's capacity.volume_dim"},
    {"tsdf.voxel_m", ParamType::kFloat, 0.0005, 0.05, "0.002", false, "voxel edge length"},
    {"tsdf.trunc_m", ParamType::kFloat, 0.001, 0.2, "0.008", false, "truncation distance"},
    // edgefused's pipeline: models, filters, tracking
    {"localize.models", ParamType::kString, 0, kParamTextMax, "", false,
     "a PLY model or a folder of them ('' : a replayed rig set's models, else model-free segments)"},
    {"filters.bilateral", ParamType::kBool, 0, 1, "false", false,
     "bilateral depth filter before integration (the sensor kind's masks always run)"},
    {"tracking.poses", ParamType::kString, 0, kParamTextMax, "icp", false,
     "'icp' (ICP against the raycast model; 'tracked' is the same), 'robot' (the robot's flange pose at the "
     "frame's stamp x the hand-eye mounting), 'robot+icp' (that pose as the prior, ICP against the map "
     "corrects it) or 'known' (every frame at the sim / replay backend's true pose; refused when the "
     "reference camera has none)"},
    {"tracking.push_every_frame", ParamType::kBool, 0, 1, "false", false,
     "tracked: integrate every frame (else when the sensor moved 1 cm or 1 degree)"},
    {"tracking.sim_truth", ParamType::kBool, 0, 1, "false", false,
     "sim / replay only: the backend's truth stands in for the robot's flange pose (tracked start pose), the "
     "rig mountings (when the calibration store and the rig set give none) and the tracking error's reference"},
    // edgefused: which cameras feed the map
    {"sensors.fuse", ParamType::kString, 0, kParamTextMax, "", false,
     "cameras feeding the map, e.g. 'xtion,tof' (the first is the reference whose poses are known or tracked); "
     "'' : hal.toml's first camera"},
    {"sensors.replay_speed", ParamType::kFloat, 0.05, 10, "1", false,
     "replayed cameras play at this multiple of the recorded rate (0.5: slow motion, for a loaded machine)"},
    // edgefused: the robot's text profile (docs/PROTOCOL.md)
    {"robot.text", ParamType::kBool, 0, 1, "true", false, "the robot's text port on/off"},
    {"robot.text_port", ParamType::kInt, 0, 65535, "5557", false,
     "the robot's text port (on link.tcp_bind; 0: any free port, printed as 'robot: HOST:PORT')"},
    {"robot.units", ParamType::kString, 0, kParamTextMax, "m", false,
     "text profile: translations in m or mm (a connection may change it: UNITS)"},
    {"robot.rotation", ParamType::kString, 0, kParamTextMax, "xyzw", false,
     "text profile: rotations as xyzw|wxyz|axisangle|kuka_abc (a connection may change it: ROTATION)"},
    {"robot.latency_us", ParamType::kInt, -1000000, 1000000, "0", false,
     "tracking.poses = robot | robot+icp: how much later the robot stamps its flange pose than the moment it "
     "describes (the pose is looked up at the frame's stamp plus this)"},
    // edgefused: the sim rig's motion
    {"sensors.sim_path", ParamType::kString, 0, kParamTextMax, "", false,
     "host-sim: the sim rig follows this TUM-format file of rig poses in the sim world ('stamp tx ty tz qx qy "
     "qz qw' per line, s and m; eased lerp/slerp between keys, a repeated pose holds: a station) instead of its "
     "circle above the bin ('' : the circle); at most 64 keys"},
};

namespace {

bool parse_bool(const char* s, double& out) {
  if (!std::strcmp(s, "true") || !std::strcmp(s, "1") || !std::strcmp(s, "on")) return out = 1, true;
  if (!std::strcmp(s, "false") || !std::strcmp(s, "0") || !std::strcmp(s, "off")) return out = 0, true;
  return false;
}

}  // namespace

ParamStore::ParamStore() {
  char err[160];
  for (int i = 0; i < kParamCount; ++i) set(i, kParamDefs[i].fallback, err, sizeof(err));
}

int ParamStore::find(const char* key) {
  for (int i = 0; i < kParamCount; ++i)
    if (!std::strcmp(kParamDefs[i].key, key)) return i;
  return -1;
}

void ParamStore::format_range(int id, char* out, size_t cap) {
  const ParamDef& d = kParamDefs[id];
  switch (d.type) {
    case ParamType::kInt: std::snprintf(out, cap, "[%.0f, %.0f]", d.min, d.max); break;
    case ParamType::kFloat: std::snprintf(out, cap, "[%g, %g]", d.min, d.max); break;
    case ParamType::kBool: std::snprintf(out, cap, "true|false"); break;
    case ParamType::kString: std::snprintf(out, cap, "text up to %.0f characters", d.max); break;
  }
}

bool ParamStore::set(int id, const char* text, char* err, size_t err_cap) {
  if (id < 0 || id >= kParamCount) {
    std::snprintf(err, err_cap, "unknown parameter");
    return false;
  }
  const ParamDef& d = kParamDefs[id];
  char range[48];
  format_range(id, range, sizeof(range));
  ParamValue& v = values_[id];
  switch (d.type) {
    case ParamType::kString: {
      const size_t n = std::strlen(text);
      if (n > d.max) {
        std::snprintf(err, err_cap, "%s: value of %zu characters is too long (allowed: %s)", d.key, n, range);
        return false;
      }
      std::memcpy(v.text, text, n + 1);
      return true;
    }
    case ParamType::kBool: {
      double b;
      if (!parse_bool(text, b)) {
        std::snprintf(err, err_cap, "%s = %.40s is not allowed (allowed: %s)", d.key, text, range);
        return false;
      }
      v.number = b;
      return true;
    }
    case ParamType::kInt:
    case ParamType::kFloat: {
      char* end = nullptr;
      const double x = d.type == ParamType::kInt ? double(std::strtoll(text, &end, 10)) : std::strtod(text, &end);
      if (end == text || *end != '\0' || !std::isfinite(x)) {
        std::snprintf(err, err_cap, "%s = %.40s is not %s (allowed: %s)", d.key, text,
                      d.type == ParamType::kInt ? "an integer" : "a number", range);
        return false;
      }
      if (x < d.min || x > d.max) {
        std::snprintf(err, err_cap, "%s = %.40s is out of range %s", d.key, text, range);
        return false;
      }
      v.number = x;
      return true;
    }
  }
  return false;
}

void ParamStore::format(int id, char* out, size_t cap) const {
  const ParamDef& d = kParamDefs[id];
  const ParamValue& v = values_[id];
  switch (d.type) {
    case ParamType::kInt: std::snprintf(out, cap, "%.0f", v.number); break;
    case ParamType::kFloat: std::snprintf(out, cap, "%g", v.number); break;
    case ParamType::kBool: std::snprintf(out, cap, "%s", v.number != 0 ? "true" : "false"); break;
    case ParamType::kString: std::snprintf(out, cap, "%s", v.text); break;
  }
}

}  // namespace edgefuse::runtime
