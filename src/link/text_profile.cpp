#include "edgefuse/link/text_profile.hpp"

#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace edgefuse::link {
namespace {

constexpr int kWordsMax = 16;    // the longest request: HANDEYE ADD + 7 numbers
constexpr size_t kWordMax = 31;  // longer words are refused (numbers need far less)
constexpr float kDegPerRad = 57.29577951308232f;

struct Words {
  const char* at[kWordsMax];
  size_t len[kWordsMax];
  int count = 0;
  const char* error = nullptr;
};

bool separator(char c) { return c == ' ' || c == '\t' || c == ',' || c == '\r'; }

// Splits at runs of spaces, tabs and commas.
void split(const char* s, size_t n, Words& w) {
  size_t i = 0;
  while (i < n) {
    while (i < n && separator(s[i])) ++i;
    if (i == n) break;
    const size_t start = i;
    while (i < n && !separator(s[i])) ++i;
    if (w.count == kWordsMax) {
      w.error = "too many words (at most 16)";
      return;
    }
    if (i - start > kWordMax) {
      w.error = "a word longer than 31 characters";
      return;
    }
    w.at[w.count] = s + start;
    w.len[w.count++] = i - start;
  }
}

// Case-insensitive comparison of a word with an upper-case keyword.
bool is(const Words& w, int i, const char* keyword) {
  if (i >= w.count || std::strlen(keyword) != w.len[i]) return false;
  for (size_t k = 0; k < w.len[i]; ++k) {
    char c = w.at[i][k];
    if (c >= 'a' && c <= 'z') c = char(c - 'a' + 'A');
    if (c != keyword[k]) return false;
  }
  return true;
}

// A word as a zero-terminated lower-case copy (for the format words).
void lower_copy(const Words& w, int i, char (&out)[kWordMax + 1]) {
  size_t k = 0;
  for (; k < w.len[i]; ++k) {
    const char c = w.at[i][k];
    out[k] = c >= 'A' && c <= 'Z' ? char(c - 'A' + 'a') : c;
  }
  out[k] = '\0';
}

bool number(const Words& w, int i, float& v) {
  char tmp[kWordMax + 1];
  std::memcpy(tmp, w.at[i], w.len[i]);
  tmp[w.len[i]] = '\0';
  char* end = nullptr;
  const double d = std::strtod(tmp, &end);
  if (end != tmp + w.len[i] || !std::isfinite(d) || std::fabs(d) > 1e9) return false;
  v = float(d);
  return true;
}

int rotation_numbers(TextRotation r) { return r == TextRotation::kXyzw || r == TextRotation::kWxyz ? 4 : 3; }

// The pose in words [first, first + 3 + rotation numbers).
const char* parse_pose(const Words& w, int first, const TextFormat& fmt, Pose& p) {
  float v[7];
  const int n = 3 + rotation_numbers(fmt.rotation);
  if (w.count - first != n)
    return n == 7 ? "a pose is 7 numbers: x y z and the quaternion" : "a pose is 6 numbers: x y z and the rotation";
  for (int i = 0; i < n; ++i)
    if (!number(w, first + i, v[i])) return "a pose value is not a number";
  const float scale = fmt.units == TextUnits::kMillimetres ? 0.001f : 1.0f;
  p = Pose();
  p.t = Vec3f(v[0], v[1], v[2]) * scale;
  if (n == 7) {
    const bool xyzw = fmt.rotation == TextRotation::kXyzw;
    const Eigen::Quaternionf q = xyzw ? Eigen::Quaternionf(v[6], v[3], v[4], v[5]) : Eigen::Quaternionf(v[3], v[4], v[5], v[6]);
    if (std::fabs(q.norm() - 1.0f) > 0.01f) return "the quaternion is not unit length";
    p.R = q.normalized().toRotationMatrix();
  } else if (fmt.rotation == TextRotation::kAxisAngle) {
    const Vec3f r(v[3], v[4], v[5]);
    const float angle = r.norm();
    if (angle > 1e-9f) p.R = Eigen::AngleAxisf(angle, r / angle).toRotationMatrix();
  } else {  // KUKA: A about z, then B about the new y, then C about the newest x
    p.R = (Eigen::AngleAxisf(v[3] / kDegPerRad, Vec3f::UnitZ()) * Eigen::AngleAxisf(v[4] / kDegPerRad, Vec3f::UnitY()) *
           Eigen::AngleAxisf(v[5] / kDegPerRad, Vec3f::UnitX()))
              .toRotationMatrix();
  }
  return nullptr;
}

void bad(TextLine& out, const char* why) {
  out.kind = TextLine::Kind::kRequest;
  out.request.command = robot::Command::kNone;
  out.request.error = why;
}

// A command with an optional (DETECT) or required (CAPTURE, POSE, HANDEYE ADD) pose from `first`.
void with_pose(const Words& w, int first, bool required, const TextFormat& fmt, robot::Command c, TextLine& out) {
  out.kind = TextLine::Kind::kRequest;
  out.request.command = c;
  if (w.count == first && !required) return;
  if (const char* why = parse_pose(w, first, fmt, out.request.T_base_flange)) return bad(out, why);
  out.request.has_pose = true;
}

void bare(const Words& w, int words, robot::Command c, TextLine& out) {
  if (w.count != words) return bad(out, "this command takes no numbers");
  out.kind = TextLine::Kind::kRequest;
  out.request.command = c;
}

void hand_eye(const Words& w, const TextFormat& fmt, TextLine& out) {
  using robot::Command;
  if (is(w, 1, "ADD")) return with_pose(w, 2, true, fmt, Command::kHandEyeAdd, out);
  if (is(w, 1, "SOLVE")) return bare(w, 2, Command::kHandEyeSolve, out);
  if (is(w, 1, "SAVE")) return bare(w, 2, Command::kHandEyeSave, out);
  if (is(w, 1, "RESET")) return bare(w, 2, Command::kHandEyeReset, out);
  bad(out, "HANDEYE takes ADD pose, SOLVE, SAVE or RESET");
}

void set_format(const Words& w, const TextFormat& fmt, TextLine& out) {
  if (w.count != 2) return bad(out, "UNITS m|mm, ROTATION xyzw|wxyz|axisangle|kuka_abc");
  char word[kWordMax + 1];
  lower_copy(w, 1, word);
  out.format = fmt;
  const bool ok = is(w, 0, "UNITS") ? parse_units(word, out.format.units) : parse_rotation(word, out.format.rotation);
  if (!ok) return bad(out, is(w, 0, "UNITS") ? "UNITS takes m or mm" : "ROTATION takes xyzw, wxyz, axisangle or kuka_abc");
  out.kind = TextLine::Kind::kFormat;
}

}  // namespace

bool parse_units(const char* s, TextUnits& out) {
  if (!std::strcmp(s, "m")) out = TextUnits::kMetres;
  else if (!std::strcmp(s, "mm")) out = TextUnits::kMillimetres;
  else return false;
  return true;
}

bool parse_rotation(const char* s, TextRotation& out) {
  if (!std::strcmp(s, "xyzw")) out = TextRotation::kXyzw;
  else if (!std::strcmp(s, "wxyz")) out = TextRotation::kWxyz;
  else if (!std::strcmp(s, "axisangle")) out = TextRotation::kAxisAngle;
  else if (!std::strcmp(s, "kuka_abc")) out = TextRotation::kKukaAbc;
  else return false;
  return true;
}

void parse_text_line(const char* line, size_t len, const TextFormat& fmt, TextLine& out) {
  using robot::Command;
  out = TextLine();
  for (size_t i = 0; i < len; ++i)
    if (line[i] == '\0' || line[i] == '\n') return bad(out, "a control character in the line");
  Words w;
  split(line, len, w);
  if (w.error != nullptr) return bad(out, w.error);
  if (w.count == 0) return;  // kEmpty
  if (is(w, 0, "CAPTURE")) return with_pose(w, 1, true, fmt, Command::kCapture, out);
  if (is(w, 0, "POSE")) return with_pose(w, 1, true, fmt, Command::kPose, out);
  if (is(w, 0, "DETECT")) return with_pose(w, 1, false, fmt, Command::kDetect, out);
  if (is(w, 0, "DETECT_ASYNC")) return with_pose(w, 1, false, fmt, Command::kDetectAsync, out);
  if (is(w, 0, "DETECT_STATUS")) return bare(w, 1, Command::kDetectStatus, out);
  if (is(w, 0, "NEXT")) return bare(w, 1, Command::kNext, out);
  if (is(w, 0, "STOP")) return bare(w, 1, Command::kStop, out);
  if (is(w, 0, "STATUS")) return bare(w, 1, Command::kStatus, out);
  if (is(w, 0, "CALIBRATION")) return bare(w, 1, Command::kCalibrationGet, out);
  if (is(w, 0, "HANDEYE")) return hand_eye(w, fmt, out);
  if (is(w, 0, "UNITS") || is(w, 0, "ROTATION")) return set_format(w, fmt, out);
  if (is(w, 0, "PICKED")) {
    if (w.count != 2 || !(is(w, 1, "OK") || is(w, 1, "FAILED"))) return bad(out, "PICKED takes OK or FAILED");
    out.kind = TextLine::Kind::kRequest;
    out.request.command = Command::kPickResult;
    out.request.picked = is(w, 1, "OK");
    return;
  }
  out.kind = TextLine::Kind::kRequest;
  out.request.command = Command::kUnknown;
}

namespace {

// Values that print as zero print as "0", never "-0" (a robot program may compare text).
double printed(float v, double half_last_digit) { return std::fabs(double(v)) < half_last_digit ? 0.0 : double(v); }

}  // namespace

size_t format_text_pose(const Pose& p, const TextFormat& fmt, char* out, size_t cap) {
  const bool mm = fmt.units == TextUnits::kMillimetres;
  const Vec3f t = p.t * (mm ? 1000.0f : 1.0f);
  const double h = mm ? 5e-4 : 5e-7;
  int n = std::snprintf(out, cap, mm ? "%.3f %.3f %.3f" : "%.6f %.6f %.6f", printed(t.x(), h), printed(t.y(), h),
                        printed(t.z(), h));
  if (n < 0 || size_t(n) >= cap) return 0;
  const Eigen::Quaternionf q = p.quaternion();
  int m = 0;
  if (fmt.rotation == TextRotation::kXyzw) {
    m = std::snprintf(out + n, cap - n, " %.7f %.7f %.7f %.7f", printed(q.x(), 5e-8), printed(q.y(), 5e-8),
                      printed(q.z(), 5e-8), printed(q.w(), 5e-8));
  } else if (fmt.rotation == TextRotation::kWxyz) {
    m = std::snprintf(out + n, cap - n, " %.7f %.7f %.7f %.7f", printed(q.w(), 5e-8), printed(q.x(), 5e-8),
                      printed(q.y(), 5e-8), printed(q.z(), 5e-8));
  } else if (fmt.rotation == TextRotation::kAxisAngle) {
    const Eigen::AngleAxisf aa(q);
    const Vec3f r = aa.axis() * aa.angle();
    m = std::snprintf(out + n, cap - n, " %.7f %.7f %.7f", printed(r.x(), 5e-8), printed(r.y(), 5e-8),
                      printed(r.z(), 5e-8));
  } else {
    const Mat3f& R = p.R;
    const float b = std::atan2(-R(2, 0), std::sqrt(R(0, 0) * R(0, 0) + R(1, 0) * R(1, 0)));
    const float a = std::atan2(R(1, 0), R(0, 0)), c = std::atan2(R(2, 1), R(2, 2));
    m = std::snprintf(out + n, cap - n, " %.4f %.4f %.4f", printed(a * kDegPerRad, 5e-5), printed(b * kDegPerRad, 5e-5),
                      printed(c * kDegPerRad, 5e-5));
  }
  if (m < 0 || size_t(n + m) >= cap) return 0;
  return size_t(n + m);
}

namespace {

const char* state_word(runtime::RuntimeState s) {
  switch (s) {
    case runtime::RuntimeState::kIdle: return "IDLE";
    case runtime::RuntimeState::kMapping: return "MAPPING";
    case runtime::RuntimeState::kLocalize: return "LOCALIZE";
    case runtime::RuntimeState::kReport: return "REPORT";
  }
  return "ERROR";
}

const char* tracking_word(runtime::TrackingState t) {
  switch (t) {
    case runtime::TrackingState::kOff: return "off";
    case runtime::TrackingState::kOk: return "ok";
    case runtime::TrackingState::kDegraded: return "degraded";
    case runtime::TrackingState::kLost: return "lost";
  }
  return "off";
}

// Appends printf text at `len`. \return the new length (cap when it did not fit)
size_t append(char* out, size_t cap, size_t len, const char* fmt, ...) __attribute__((format(printf, 4, 5)));
size_t append(char* out, size_t cap, size_t len, const char* fmt, ...) {
  if (len >= cap) return cap;
  va_list a;
  va_start(a, fmt);
  const int n = std::vsnprintf(out + len, cap - len, fmt, a);
  va_end(a);
  return n < 0 || size_t(n) >= cap - len ? cap : len + size_t(n);
}

size_t append_pose(char* out, size_t cap, size_t len, const Pose& p, const TextFormat& fmt) {
  if (len + 1 >= cap) return cap;
  out[len++] = ' ';
  const size_t n = format_text_pose(p, fmt, out + len, cap - len);
  return n == 0 ? cap : len + n;
}

// "ERR code NAME message": the message's line ends become spaces (one reply, one line).
size_t error_line(const robot::Reply& r, char* out, size_t cap) {
  size_t len = append(out, cap, 0, "ERR %d %s", int(r.status), robot::to_string(r.status));
  if (r.message[0] != '\0') len = append(out, cap, len, " %s", r.message);
  for (size_t i = 0; i < len && i < cap; ++i)
    if (out[i] == '\n' || out[i] == '\r') out[i] = ' ';
  return len;
}

size_t ok_line(const robot::Reply& r, const TextFormat& fmt, char* out, size_t cap) {
  using robot::Command;
  switch (r.command) {
    case Command::kDetect:
    case Command::kDetectStatus: return append(out, cap, 0, "OK %u", unsigned(r.count));
    case Command::kNext: {
      if (!r.has_object) return append(out, cap, 0, "NO_OBJECTS");
      size_t len = append(out, cap, 0, "OBJECT %u", unsigned(r.object.id));
      len = append_pose(out, cap, len, r.object.T_world_object, fmt);
      len = append(out, cap, len, " %.4f", double(r.object.score));
      len = append_pose(out, cap, len, r.T_base_grasp, fmt);
      return append(out, cap, len, " %u", unsigned(r.left));
    }
    case Command::kPickResult: return append(out, cap, 0, "OK %u", unsigned(r.left));
    case Command::kStatus:
      return append(out, cap, 0, "OK %s %s %u %u %u", state_word(r.state), tracking_word(r.tracking),
                    unsigned(r.count), unsigned(r.left), unsigned(r.stations));
    case Command::kHandEyeAdd: return append(out, cap, 0, "OK %u", unsigned(r.count));
    case Command::kHandEyeSolve: {
      const size_t len = append_pose(out, cap, append(out, cap, 0, "OK"), r.T_flange_camera, fmt);
      return append(out, cap, len, " %.3f %.4f", double(r.residual_mm), double(r.residual_deg));
    }
    case Command::kCalibrationGet: return append_pose(out, cap, append(out, cap, 0, "OK"), r.T_flange_camera, fmt);
    default: return append(out, cap, 0, "OK");
  }
}

}  // namespace

size_t format_text_reply(const robot::Reply& r, const TextFormat& fmt, char* out, size_t cap) {
  if (cap < 2) return 0;
  size_t len = 0;
  if (r.status == robot::ReplyStatus::kOk) {
    if (r.command == robot::Command::kPose) return 0;  // streamed: no reply
    len = ok_line(r, fmt, out, cap - 1);
  } else if (r.status == robot::ReplyStatus::kNoObjects) {
    len = append(out, cap - 1, 0, "NO_OBJECTS");
  } else if (r.status == robot::ReplyStatus::kRunning) {
    len = append(out, cap - 1, 0, "RUNNING");
  } else {
    len = error_line(r, out, cap - 1);
  }
  if (len >= cap - 1) len = cap - 2;  // cut short rather than lose the line end
  out[len++] = '\n';
  out[len] = '\0';
  return len;
}

TextLineBuffer::Event TextLineBuffer::push(char b) {
  if (line_done_) {
    len_ = 0;
    line_done_ = false;
  }
  if (b == '\n') {
    if (overlong_) {
      overlong_ = false;
      len_ = 0;
      return Event::kTooLong;
    }
    buf_[len_] = '\0';
    line_done_ = true;
    return Event::kLine;
  }
  if (overlong_) return Event::kNone;
  if (len_ == kTextLineMax) {
    overlong_ = true;
    return Event::kNone;
  }
  buf_[len_++] = b;
  return Event::kNone;
}

}  // namespace edgefuse::link
