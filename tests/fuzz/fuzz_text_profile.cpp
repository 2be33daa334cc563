// Fuzz target for the robot's text profile (src/link/text_profile.cpp): any bytes a robot program,
// a terminal or a confused script sends to the text port. The input is a byte stream cut into
// lines by the connection's line buffer; every line is parsed in the connection's format (UNITS
// and ROTATION lines change it) and each request's possible replies are formatted.
// Invariants:
//   - no crash or sanitizer report, whatever the bytes;
//   - a line is a request, a format change or empty; an unreadable request carries its reason;
//   - a parsed pose is finite with an orthonormal rotation, and formatting it in the connection's
//     format and parsing it back gives the same pose;
//   - every reply is one printable line ending in "\n", within kTextReplyMax.
#include <cmath>
#include <cstdint>
#include <cstring>

#include "edgefuse/link/text_profile.hpp"
#include "fuzz_check.hpp"

namespace {

using namespace edgefuse;
using namespace edgefuse::link;

void check_reply(const robot::Reply& r, const TextFormat& fmt) {
  static char out[kTextReplyMax];
  const size_t n = format_text_reply(r, fmt, out, sizeof out);
  if (n == 0) return;
  FUZZ_CHECK(n < sizeof out && out[n - 1] == '\n', "a reply of %zu bytes does not end in a line end", n);
  for (size_t i = 0; i + 1 < n; ++i)
    FUZZ_CHECK(out[i] >= 0x20 && out[i] <= 0x7E, "a reply holds the byte 0x%02x", unsigned(uint8_t(out[i])));
}

void check_pose(const Pose& p, const TextFormat& fmt) {
  FUZZ_CHECK(p.t.allFinite() && p.R.allFinite(), "a parsed pose is not finite");
  FUZZ_CHECK((p.R * p.R.transpose() - Mat3f::Identity()).norm() < 1e-4f, "a parsed rotation is not orthonormal");
  static char text[200];
  std::memcpy(text, "POSE ", 5);
  const size_t n = format_text_pose(p, fmt, text + 5, sizeof text - 5);
  FUZZ_CHECK(n > 0, "a parsed pose does not format");
  static TextLine again;
  parse_text_line(text, 5 + n, fmt, again);
  FUZZ_CHECK(again.request.command == robot::Command::kPose, "a formatted pose does not parse: %s", text);
  const Pose& q = again.request.T_base_flange;
  // Printed with 6 (m) or 3 (mm) decimals: within a micrometre plus float rounding of large values.
  const float tol_m = 2e-6f + 1e-6f * p.t.norm();
  FUZZ_CHECK((q.t - p.t).norm() <= tol_m, "a pose moved by %g m formatted and parsed", double((q.t - p.t).norm()));
  FUZZ_CHECK((q.inverse() * p).angle_rad() < 1e-3f, "a pose turned by %g rad formatted and parsed",
             double((q.inverse() * p).angle_rad()));
}

void check_line(const TextLine& t, const TextFormat& fmt) {
  if (t.kind != TextLine::Kind::kRequest) return;
  const robot::Request& r = t.request;
  FUZZ_CHECK(r.command != robot::Command::kNone || r.error != nullptr, "a bad request without a reason");
  if (r.has_pose) check_pose(r.T_base_flange, fmt);
  robot::Reply reply;
  reply.command = r.command;
  for (int s = 0; s <= int(robot::ReplyStatus::kRunning); ++s) {
    reply.status = robot::ReplyStatus(s);
    reply.has_object = reply.has_hand_eye = r.has_pose;
    reply.object.T_world_object = reply.T_base_grasp = reply.T_flange_camera = r.T_base_flange;
    std::snprintf(reply.message, sizeof reply.message, "%s", r.error != nullptr ? r.error : "");
    check_reply(reply, fmt);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static TextLineBuffer lines;
  static TextLine t;
  lines.reset();
  TextFormat fmt;
  // The whole input as one line too (the parser's bound is the caller's: any length).
  parse_text_line(reinterpret_cast<const char*>(data), size, fmt, t);
  check_line(t, fmt);
  for (size_t i = 0; i < size; ++i) {
    const TextLineBuffer::Event e = lines.push(char(data[i]));
    if (e != TextLineBuffer::Event::kLine) continue;
    FUZZ_CHECK(lines.size() <= kTextLineMax, "a %zu-byte line from the line buffer", lines.size());
    parse_text_line(lines.line(), lines.size(), fmt, t);
    check_line(t, fmt);
    if (t.kind == TextLine::Kind::kFormat) fmt = t.format;
  }
  return 0;
}
