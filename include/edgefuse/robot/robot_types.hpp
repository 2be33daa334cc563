// Requests from a robot controller and the replies to them, in plain types: what the protobuf
// and text codecs at the link's edge (src/link/robot_codec.*, text_profile.*) convert to and from.
// Poses are in metres and the robot's base frame; nothing here knows a wire format.
#pragma once

#include <cstdint>

#include "edgefuse/math/pose.hpp"
#include "edgefuse/runtime/publisher.hpp"

namespace edgefuse::robot {

//! What a request asks (the numbering is the wire's RobotCommand).
enum class Command : uint8_t {
  kNone = 0,          //!< no command (an unreadable request): answered kBadRequest
  kCapture = 1,       //!< start mapping; the flange pose and its stamp are recorded
  kPose = 2,          //!< flange pose update, no reply
  kStop = 3,          //!< stop mapping
  kDetect = 4,        //!< localise now, reply when done
  kDetectAsync = 5,   //!< localise now, reply at once
  kDetectStatus = 6,  //!< kRunning while localising, else the last detect's outcome
  kNext = 7,          //!< next object in picking order
  kPickResult = 8,    //!< the last offered object was picked or not
  kStatus = 9,
  kHandEyeAdd = 10,
  kHandEyeSolve = 11,
  kHandEyeSave = 12,
  kHandEyeReset = 13,
  kCalibrationGet = 14,
  kUnknown = 255,     //!< a command number this board does not know
};

//! A reply's status (the numbering is the wire's ReplyStatus).
enum class ReplyStatus : uint8_t {
  kOk = 0,
  kNoObjects = 1,
  kBusy = 2,
  kNotCalibrated = 3,
  kBadRequest = 4,
  kUnknownCommand = 5,
  kFailed = 6,
  kRunning = 7,
};
//! The status's name as the text profile writes it ("NO_OBJECTS").
inline const char* to_string(ReplyStatus s) {
  switch (s) {
    case ReplyStatus::kOk: return "OK";
    case ReplyStatus::kNoObjects: return "NO_OBJECTS";
    case ReplyStatus::kBusy: return "BUSY";
    case ReplyStatus::kNotCalibrated: return "NOT_CALIBRATED";
    case ReplyStatus::kBadRequest: return "BAD_REQUEST";
    case ReplyStatus::kUnknownCommand: return "UNKNOWN_COMMAND";
    case ReplyStatus::kFailed: return "FAILED";
    case ReplyStatus::kRunning: return "RUNNING";
  }
  return "FAILED";
}

//! Longest reason text a reply carries (without its terminating zero).
inline constexpr int kReplyMessageMax = 63;

struct Request {
  uint32_t id = 0;               //!< echoed in the reply
  Command command = Command::kNone;
  bool has_pose = false;         //!< T_base_flange was given
  Pose T_base_flange;            //!< the flange's pose in the robot's base frame (m)
  uint64_t stamp_us = 0;         //!< the pose's time, board clock (0: when received)
  bool picked = false;           //!< kPickResult: true picked, false failed
  const char* error = nullptr;   //!< kNone: why the request could not be read (static text)
};

struct Reply {
  uint32_t id = 0;                       //!< the request's id
  Command command = Command::kNone;      //!< the request's command
  ReplyStatus status = ReplyStatus::kOk;
  uint32_t count = 0;                    //!< detect: objects found; hand-eye add: stations held
  uint32_t left = 0;                     //!< next, status: objects still to offer after this one
  bool has_object = false;               //!< next: object and grasp are set
  runtime::ObjectResult object;          //!< next: the object (base frame)
  Pose T_base_grasp;                     //!< next: the gripper's pose (the object pose: no grasp planner yet)
  bool has_hand_eye = false;             //!< hand-eye solve, calibration get: T_flange_camera is set
  Pose T_flange_camera;                  //!< the camera's mounting on the flange
  float residual_mm = 0;                 //!< hand-eye solve: RMS station residual
  float residual_deg = 0;                //!< hand-eye solve: RMS station residual
  runtime::RuntimeState state = runtime::RuntimeState::kIdle;      //!< status
  runtime::TrackingState tracking = runtime::TrackingState::kOff;  //!< status
  uint32_t stations = 0;                 //!< status: hand-eye stations held
  char message[kReplyMessageMax + 1] = {};  //!< why, for errors
};

//! Where replies go: the link's edge encodes them for the client that asked.
class ReplySink {
 public:
  virtual ~ReplySink() = default;
  //! \param client the requesting client (as given to RobotSession::handle)  \param r the reply
  virtual void reply(int client, const Reply& r) = 0;
};

}  // namespace edgefuse::robot
