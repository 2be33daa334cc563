// The robot's requests at the link's edge: protobuf requests framed, streamed and decoded back
// (garbled frames, unknown commands, bad poses become answered errors), replies encoded and
// decoded, the text profile's grammar (separators, units, rotation conventions, every command),
// malformed lines, reply lines, the line buffer's bound, and no heap while parsing or formatting.
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "edgefuse/link/robot_codec.hpp"
#include "edgefuse/link/text_profile.hpp"

#include <CppUTest/TestHarness.h>

using namespace edgefuse;
using namespace edgefuse::link;
using robot::Command;
using robot::ReplyStatus;

namespace {

class Collect : public RequestHandler {
 public:
  std::vector<robot::Request> got;
  void request(int, const robot::Request& r) override { got.push_back(r); }
};

std::vector<uint8_t> frame_of(const robot::Request& r) {
  static Message m;
  request_message(r, m);
  static FrameWriter w;
  size_t n = 0;
  const uint8_t* f = w.encode(m, n);
  return std::vector<uint8_t>(f, f + n);
}

TextLine parse(const std::string& line, TextFormat fmt = TextFormat()) {
  TextLine t;
  parse_text_line(line.data(), line.size(), fmt, t);
  return t;
}

std::string reply_line(const robot::Reply& r, TextFormat fmt = TextFormat()) {
  char buf[kTextReplyMax];
  const size_t n = format_text_reply(r, fmt, buf, sizeof buf);
  return std::string(buf, n);
}

bool near(const Pose& a, const Pose& b, float tol_m = 1e-5f, float tol_rad = 1e-4f) {
  return (a.t - b.t).norm() < tol_m && (a.inverse() * b).angle_rad() < tol_rad;
}

}  // namespace

TEST_GROUP(RobotProtobuf){};

TEST(RobotProtobuf, RequestsSurviveFramingAndTheStream) {
  robot::Request r;
  r.id = 77;
  r.command = Command::kCapture;
  r.has_pose = true;
  r.T_base_flange = Pose::from_tq(0.5f, -0.25f, 0.75f, 0.0f, 0.7071068f, 0.0f, 0.7071068f);
  r.stamp_us = 123456789;
  std::vector<uint8_t> bytes = frame_of(r);
  robot::Request pose = r;
  pose.id = 78;
  pose.command = Command::kPose;
  const std::vector<uint8_t> second = frame_of(pose);
  bytes.insert(bytes.end(), second.begin(), second.end());
  RequestStreams streams;
  Collect c;
  streams.feed(2, bytes.data(), bytes.size(), c);
  LONGS_EQUAL(2, c.got.size());
  LONGS_EQUAL(77, c.got[0].id);
  CHECK(c.got[0].command == Command::kCapture && c.got[0].has_pose);
  CHECK(near(c.got[0].T_base_flange, r.T_base_flange));
  CHECK(c.got[0].stamp_us == 123456789u);
  CHECK(c.got[1].command == Command::kPose);
}

TEST(RobotProtobuf, GarbledFramesUnknownCommandsAndBadPosesBecomeErrors) {
  RequestStreams streams;
  Collect c;
  robot::Request r;
  r.id = 5;
  r.command = Command::kNext;
  std::vector<uint8_t> f = frame_of(r);
  f[2] ^= 0x40;  // a flipped bit: the CRC fails
  streams.feed(0, f.data(), f.size(), c);
  LONGS_EQUAL(1, c.got.size());
  CHECK(c.got[0].command == Command::kNone);
  STRCMP_EQUAL("frame failed its CRC", c.got[0].error);
  LONGS_EQUAL(1, streams.stats(0).crc_errors);

  r.command = Command::kUnknown;  // encoded as command 99
  f = frame_of(r);
  streams.feed(0, f.data(), f.size(), c);
  CHECK(c.got[1].command == Command::kUnknown);
  LONGS_EQUAL(5, c.got[1].id);

  r.command = Command::kNone;  // no command at all
  f = frame_of(r);
  streams.feed(0, f.data(), f.size(), c);
  CHECK(c.got[2].command == Command::kNone);

  // A heartbeat is not a request.
  static FrameWriter w;
  size_t n = 0;
  const uint8_t* hb = w.encode(make_heartbeat(1, 2), n);
  streams.feed(0, hb, n, c);
  STRCMP_CONTAINS("not a request", c.got[3].error);

  // Not a protobuf message at all (valid framing).
  const uint8_t junk[] = {0xFF, 0xFF, 0xFF};
  uint8_t scratch[16], frame[16];
  n = frame_encode(junk, sizeof junk, scratch, sizeof scratch, frame, sizeof frame);
  streams.feed(0, frame, n, c);
  CHECK(c.got[4].command == Command::kNone);

  // A quaternion that is not unit length.
  Message m;
  robot::Request posed;
  posed.command = Command::kCapture;
  posed.has_pose = true;
  request_message(posed, m);
  m.body.request.T_base_flange.orientation.w = 3.0f;
  const uint8_t* bad = w.encode(m, n);
  streams.feed(0, bad, n, c);
  CHECK(c.got[5].command == Command::kNone);
  STRCMP_CONTAINS("unit length", c.got[5].error);

  // An overlong frame: counted, reported once, and the next frame decodes.
  std::vector<uint8_t> flood(kMaxFrame + 10, 0x55);
  flood.push_back(0);
  streams.feed(0, flood.data(), flood.size(), c);
  STRCMP_CONTAINS("longer", c.got[6].error);
  r.command = Command::kStatus;
  f = frame_of(r);
  streams.feed(0, f.data(), f.size(), c);
  CHECK(c.got.back().command == Command::kStatus);
}

TEST(RobotProtobuf, RepliesEncodeAndDecode) {
  robot::Reply r;
  r.id = 9;
  r.command = Command::kNext;
  r.left = 4;
  r.has_object = true;
  r.object.id = 2;
  r.object.score = 0.8f;
  r.object.T_world_object = Pose::from_tq(0.4f, 0.1f, 0.02f, 0, 0, 0.3826834f, 0.9238795f);
  r.T_base_grasp = r.object.T_world_object;
  std::snprintf(r.message, sizeof r.message, "%s", "fine");
  ReplyWriter w;
  size_t n = 0;
  uint8_t* f = const_cast<uint8_t*>(w.encode(r, n));
  CHECK(f != nullptr);
  std::vector<uint8_t> copy(f, f + n);
  size_t len = 0;
  CHECK(frame_decode_inplace(copy.data(), copy.size(), len));
  Message m;
  CHECK(decode_message(copy.data(), len, m));
  LONGS_EQUAL(edgefuse_link_Message_reply_tag, m.which_body);
  LONGS_EQUAL(9, m.body.reply.id);
  LONGS_EQUAL(edgefuse_link_RobotCommand_COMMAND_NEXT, m.body.reply.command);
  LONGS_EQUAL(4, m.body.reply.left);
  LONGS_EQUAL(2, m.body.reply.object.id);
  CHECK(near(object_pose(m.body.reply.object), r.object.T_world_object));
  STRCMP_EQUAL("fine", m.body.reply.message);
}

TEST(RobotProtobuf, NoHeapWhileDecodingRequestsAndEncodingReplies) {
  robot::Request r;
  r.id = 3;
  r.command = Command::kPose;
  r.has_pose = true;
  std::vector<uint8_t> f = frame_of(r);
  std::vector<uint8_t> garbled = f;
  garbled[1] ^= 0x01;
  static RequestStreams streams;
  static ReplyWriter w;
  class Count : public RequestHandler {
   public:
    int n = 0;
    void request(int, const robot::Request&) override { ++n; }
  } count;
  robot::Reply reply;
  reply.has_object = reply.has_hand_eye = true;
  edgefuse_test::alloc_count_start();
  size_t len = 0;
  for (int k = 0; k < 100; ++k) {
    streams.feed(1, f.data(), f.size(), count);
    streams.feed(1, garbled.data(), garbled.size(), count);
    CHECK(w.encode(reply, len) != nullptr);
  }
  LONGS_EQUAL(0, edgefuse_test::alloc_count());
  LONGS_EQUAL(200, count.n);
}

TEST_GROUP(RobotText){};

TEST(RobotText, PosesWithSpacesCommasUnitsAndRotations) {
  const Pose want = Pose::from_tq(0.5f, -0.25f, 0.125f, 0.0f, 0.0f, 0.3826834f, 0.9238795f);
  TextLine t = parse("CAPTURE 0.5 -0.25 0.125 0 0 0.3826834 0.9238795");
  CHECK(t.kind == TextLine::Kind::kRequest && t.request.command == Command::kCapture && t.request.has_pose);
  CHECK(near(t.request.T_base_flange, want));
  t = parse("capture 0.5,-0.25,0.125, 0,0,0.3826834,0.9238795\r");  // commas, lower case, CR
  CHECK(t.request.command == Command::kCapture && near(t.request.T_base_flange, want));
  TextFormat f;
  for (TextRotation rot : {TextRotation::kXyzw, TextRotation::kWxyz, TextRotation::kAxisAngle, TextRotation::kKukaAbc})
    for (TextUnits u : {TextUnits::kMetres, TextUnits::kMillimetres}) {
      f.rotation = rot;
      f.units = u;
      char buf[160];
      CHECK(format_text_pose(want, f, buf, sizeof buf) > 0);
      t = parse(std::string("POSE ") + buf, f);
      CHECK_TEXT(t.request.command == Command::kPose && near(t.request.T_base_flange, want, 2e-6f, 2e-4f), buf);
    }
  f.units = TextUnits::kMillimetres;
  f.rotation = TextRotation::kKukaAbc;
  t = parse("POSE 500 -250 125 45 0 0", f);  // KUKA A = 45 degrees about z
  CHECK(near(t.request.T_base_flange, want, 1e-5f, 1e-4f));
}

TEST(RobotText, EveryCommandWord) {
  CHECK(parse("DETECT").request.command == Command::kDetect);
  CHECK_FALSE(parse("DETECT").request.has_pose);
  CHECK(parse("DETECT 0 0 0 0 0 0 1").request.has_pose);
  CHECK(parse("DETECT_ASYNC").request.command == Command::kDetectAsync);
  CHECK(parse("DETECT_STATUS").request.command == Command::kDetectStatus);
  CHECK(parse("NEXT").request.command == Command::kNext);
  CHECK(parse("STOP").request.command == Command::kStop);
  CHECK(parse("STATUS").request.command == Command::kStatus);
  CHECK(parse("CALIBRATION").request.command == Command::kCalibrationGet);
  TextLine t = parse("PICKED OK");
  CHECK(t.request.command == Command::kPickResult && t.request.picked);
  t = parse("picked failed");
  CHECK(t.request.command == Command::kPickResult && !t.request.picked);
  CHECK(parse("HANDEYE ADD 0 0 0 0 0 0 1").request.command == Command::kHandEyeAdd);
  CHECK(parse("HANDEYE SOLVE").request.command == Command::kHandEyeSolve);
  CHECK(parse("HANDEYE SAVE").request.command == Command::kHandEyeSave);
  CHECK(parse("HANDEYE RESET").request.command == Command::kHandEyeReset);
  t = parse("UNITS mm");
  CHECK(t.kind == TextLine::Kind::kFormat && t.format.units == TextUnits::kMillimetres);
  t = parse("ROTATION kuka_abc");
  CHECK(t.kind == TextLine::Kind::kFormat && t.format.rotation == TextRotation::kKukaAbc);
  CHECK(parse("").kind == TextLine::Kind::kEmpty);
  CHECK(parse("  \r").kind == TextLine::Kind::kEmpty);
  CHECK(parse("JUMP").request.command == Command::kUnknown);
}

TEST(RobotText, MalformedLinesBecomeBadRequests) {
  const char* bad[] = {
      "CAPTURE",                             // no pose
      "CAPTURE 1 2 3",                       // too few numbers
      "CAPTURE 1 2 3 0 0 0 1 9",             // too many
      "CAPTURE 1 2 x 0 0 0 1",               // not a number
      "CAPTURE 1 2 3 0 0 0 2",               // not a unit quaternion
      "CAPTURE 1 2 3 0 0 0 nan",             // not finite
      "CAPTURE 1e300 2 3 0 0 0 1",           // absurd
      "POSE 0 0 0 0 0 0",                    // 6 numbers in xyzw
      "NEXT 1",                              // arguments where none belong
      "PICKED",                              // PICKED without OK/FAILED
      "PICKED MAYBE",
      "HANDEYE",                             // no sub-command
      "HANDEYE FLY",
      "UNITS inch",
      "ROTATION euler",
      "UNITS",
      "1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17",  // too many words
      "CAPTURE 0.123456789012345678901234567890123 0 0 0 0 0 1",  // a word too long
  };
  for (const char* line : bad) {
    const TextLine t = parse(line);
    CHECK_TEXT(t.kind == TextLine::Kind::kRequest && t.request.command == Command::kNone && t.request.error, line);
  }
  const std::string with_nul("NEXT\0X", 6);
  CHECK(parse(with_nul).request.command == Command::kNone);
}

TEST(RobotText, ReplyLines) {
  robot::Reply r;
  r.command = Command::kCapture;
  STRCMP_EQUAL("OK\n", reply_line(r).c_str());
  r.command = Command::kPose;
  STRCMP_EQUAL("", reply_line(r).c_str());  // streamed: no reply
  r.command = Command::kDetect;
  r.count = 3;
  STRCMP_EQUAL("OK 3\n", reply_line(r).c_str());
  r.status = ReplyStatus::kNoObjects;
  STRCMP_EQUAL("NO_OBJECTS\n", reply_line(r).c_str());
  r.status = ReplyStatus::kFailed;
  std::snprintf(r.message, sizeof r.message, "%s", "the map is empty\n(scan)");
  STRCMP_EQUAL("ERR 6 FAILED the map is empty (scan)\n", reply_line(r).c_str());
  r = robot::Reply();
  r.command = Command::kNext;
  r.has_object = true;
  r.object.id = 2;
  r.object.score = 0.88f;
  r.object.T_world_object = Pose::from_tq(0.475f, 0.02f, 0.045f, 0, 0, 0, 1);
  r.T_base_grasp = r.object.T_world_object;
  r.T_base_grasp.t.z() += 0.01f;
  r.left = 1;
  STRCMP_EQUAL(
      "OBJECT 2 0.475000 0.020000 0.045000 0.0000000 0.0000000 0.0000000 1.0000000 0.8800 0.475000 0.020000 "
      "0.055000 0.0000000 0.0000000 0.0000000 1.0000000 1\n",
      reply_line(r).c_str());
  TextFormat mm;
  mm.units = TextUnits::kMillimetres;
  mm.rotation = TextRotation::kWxyz;
  STRCMP_CONTAINS("OBJECT 2 475.000 20.000 45.000 1.0000000 0.0000000 0.0000000 0.0000000 0.8800",
                  reply_line(r, mm).c_str());
  char pose[160];
  TextFormat kuka;
  kuka.rotation = TextRotation::kKukaAbc;
  format_text_pose(Pose::from_tq(0, 0, 0, 0.7071068f, 0, 0, 0.7071068f), kuka, pose, sizeof pose);
  STRCMP_EQUAL("0.000000 0.000000 0.000000 0.0000 0.0000 90.0000", pose);  // no "-0.0000"
  r = robot::Reply();
  r.command = Command::kStatus;
  r.state = runtime::RuntimeState::kMapping;
  r.tracking = runtime::TrackingState::kOk;
  r.count = 3;
  r.left = 2;
  r.stations = 1;
  STRCMP_EQUAL("OK MAPPING ok 3 2 1\n", reply_line(r).c_str());
  r = robot::Reply();
  r.command = Command::kHandEyeSolve;
  r.has_hand_eye = true;
  r.residual_mm = 0.25f;
  r.residual_deg = 0.01f;
  STRCMP_EQUAL("OK 0.000000 0.000000 0.000000 0.0000000 0.0000000 0.0000000 1.0000000 0.250 0.0100\n",
               reply_line(r).c_str());
  r = robot::Reply();
  r.status = ReplyStatus::kUnknownCommand;
  STRCMP_EQUAL("ERR 5 UNKNOWN_COMMAND\n", reply_line(r).c_str());
  char tiny[8];
  r.status = ReplyStatus::kBadRequest;
  std::snprintf(r.message, sizeof r.message, "%s", "a long reason that does not fit");
  const size_t n = format_text_reply(r, TextFormat(), tiny, sizeof tiny);
  LONGS_EQUAL(7, n);
  LONGS_EQUAL('\n', tiny[6]);  // cut short, still one line
}

TEST(RobotText, LineBufferBoundsLines) {
  TextLineBuffer b;
  const std::string ok = "NEXT\n";
  TextLineBuffer::Event e = TextLineBuffer::Event::kNone;
  for (char ch : ok) e = b.push(ch);
  CHECK(e == TextLineBuffer::Event::kLine);
  STRCMP_EQUAL("NEXT", b.line());
  int too_long = 0, lines = 0;
  for (int i = 0; i < 1000; ++i) too_long += b.push('A') == TextLineBuffer::Event::kTooLong;
  too_long += b.push('\n') == TextLineBuffer::Event::kTooLong;
  for (char ch : std::string("STATUS\n")) lines += b.push(ch) == TextLineBuffer::Event::kLine;
  LONGS_EQUAL(1, too_long);
  LONGS_EQUAL(1, lines);
  STRCMP_EQUAL("STATUS", b.line());
}

TEST(RobotText, NoHeapWhileParsingAndFormatting) {
  const char* lines[] = {"CAPTURE 0.5 -0.25 0.125 0 0 0.3826834 0.9238795", "NEXT", "PICKED OK", "garbage 1 2",
                         "HANDEYE ADD 1,2,3,0,0,0,1", "ROTATION axisangle"};
  TextLine t;
  robot::Reply r;
  r.command = Command::kNext;
  r.has_object = true;
  char out[kTextReplyMax];
  edgefuse_test::alloc_count_start();
  size_t total = 0;
  for (int k = 0; k < 100; ++k)
    for (const char* l : lines) {
      parse_text_line(l, std::strlen(l), TextFormat(), t);
      total += format_text_reply(r, TextFormat(), out, sizeof out);
    }
  LONGS_EQUAL(0, edgefuse_test::alloc_count());
  CHECK(total > 0);
}
