// The robot's text profile (docs/PROTOCOL.md, "Text profile"): one request per line, one reply per
// line, for robot languages without protobuf (URScript, KRL, RAPID, Karel). The parser is a pure
// function over a bounded line (it is fuzzed: tests/fuzz/fuzz_text_profile.cpp); the connection's
// units and rotation convention (UNITS, ROTATION) are its per-connection format. Replies are
// formatted into a caller's buffer. No OS, no heap.
#pragma once

#include <cstddef>
#include <cstdint>

#include "edgefuse/robot/robot_types.hpp"

namespace edgefuse::link {

//! Longest request line (without its line end); longer lines are answered with an error.
inline constexpr size_t kTextLineMax = 255;
//! Longest reply line (line end included).
inline constexpr size_t kTextReplyMax = 256;

enum class TextUnits : uint8_t { kMetres, kMillimetres };
//! How a pose's rotation is written: quaternion x y z w, quaternion w x y z, rotation vector
//! rx ry rz in radians (URScript), KUKA A B C in degrees (R = Rz(A) Ry(B) Rx(C)).
enum class TextRotation : uint8_t { kXyzw, kWxyz, kAxisAngle, kKukaAbc };

//! A connection's pose format.
struct TextFormat {
  TextUnits units = TextUnits::kMetres;          //!< translations in m or mm
  TextRotation rotation = TextRotation::kXyzw;   //!< rotation convention
};

//! Parses "m" / "mm". \param s the word \param out set on success
bool parse_units(const char* s, TextUnits& out);
//! Parses "xyzw" / "wxyz" / "axisangle" / "kuka_abc". \param s the word \param out set on success
bool parse_rotation(const char* s, TextRotation& out);

//! What one line asks.
struct TextLine {
  enum class Kind : uint8_t {
    kEmpty,    //!< a blank line: ignored, no reply
    kRequest,  //!< `request` for the session (Command::kNone with `request.error` when unreadable)
    kFormat,   //!< UNITS / ROTATION: `format` is the connection's new format; reply "OK"
  };
  Kind kind = Kind::kEmpty;
  robot::Request request;  //!< kRequest
  TextFormat format;       //!< kFormat
};

//! Parses one line (without its line end; a trailing '\r' is ignored).
//! \param line the bytes (need not be zero-terminated; any byte value)  \param len their number
//! \param fmt the connection's current format  \param out the result
void parse_text_line(const char* line, size_t len, const TextFormat& fmt, TextLine& out);

//! Formats a reply as one line ending in "\n".
//! \param r the reply  \param fmt the connection's format  \param out the buffer  \param cap its size
//! \return the line's length, 0 for a reply that sends nothing
size_t format_text_reply(const robot::Reply& r, const TextFormat& fmt, char* out, size_t cap);

//! Formats a pose in `fmt`: "x y z" then the rotation's numbers. \return the length written
size_t format_text_pose(const Pose& p, const TextFormat& fmt, char* out, size_t cap);

//! Collects a connection's bytes into lines. A line longer than kTextLineMax is reported once as
//! too long and its rest skipped up to the line end.
class TextLineBuffer {
 public:
  //! Result of push(): nothing yet, a line complete (line()/size()), or an overlong line ended.
  enum class Event : uint8_t { kNone, kLine, kTooLong };
  //! \param b the next byte
  Event push(char b);
  const char* line() const { return buf_; }
  size_t size() const { return len_; }
  void reset() {
    len_ = 0;
    overlong_ = false;
  }

 private:
  char buf_[kTextLineMax + 1] = {};
  size_t len_ = 0;
  bool overlong_ = false;
  bool line_done_ = false;
};

}  // namespace edgefuse::link
