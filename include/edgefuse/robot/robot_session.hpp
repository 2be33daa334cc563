// The robot's side of the runtime: requests from robot controllers (capture, pose updates, detect,
// next object, pick results, hand-eye stations, calibration) answered in plain types
// (robot_types.hpp). One session serves every client of the link and of the text port: they share
// one map, one object list and one hand-eye station list, as they share one robot.
//
// Object list: every localisation result (a detect, the console's `localize`, the still trigger)
// replaces it, in the result's picking order. NEXT offers the next object after the last offered
// one that is still in the list (so a client that never reports picks still walks the list to
// NO_OBJECTS); PICK_RESULT takes the last offered object out of the list, picked or failed, so a
// failed object is not offered again before the next detect.
// Detect: starts the runtime's localisation (or joins the one running) and answers every waiting
// client when the result arrives; right after CAPTURE the map may still be empty, so the start is
// retried for kMapWaitUs while mapping. Flange poses (CAPTURE, POSE, DETECT, HANDEYE ADD) go into
// a stamped history (flange_poses()) for the tracking to look poses up by frame stamp.
// No OS calls, no heap, fixed capacities: runs inside the firmware's service loop.
#pragma once

#include <cstdint>

#include "edgefuse/fusion/hand_eye.hpp"
#include "edgefuse/pipeline/pose_history.hpp"
#include "edgefuse/robot/robot_types.hpp"
#include "edgefuse/runtime/flange_pose_source.hpp"
#include "edgefuse/runtime/runtime.hpp"

namespace edgefuse::robot {

struct SessionCounters {
  uint32_t requests = 0;          //!< requests handled (pose updates included)
  uint32_t pose_updates = 0;      //!< POSE requests
  uint32_t bad_requests = 0;      //!< unreadable or invalid requests (answered kBadRequest)
  uint32_t unknown_commands = 0;  //!< unknown commands (answered kUnknownCommand)
  uint32_t poses_refused = 0;     //!< flange poses whose stamp did not increase
  uint32_t replies = 0;           //!< replies sent
};

class RobotSession final : public runtime::ResultListener, public runtime::FlangePoseSource {
 public:
  //! Waiting detect requests at most (one per client fits: 8 TCP + serial + 8 text clients).
  static constexpr int kPendingMax = 24;
  //! How long a detect waits for the first frames after CAPTURE (empty map) before it fails.
  static constexpr uint64_t kMapWaitUs = 2000000;

  //! \param rt the runtime (state machine, calibration)  \param pipeline its pipeline (rig pose
  //! for hand-eye stations)  \param out where replies go
  RobotSession(runtime::Runtime& rt, runtime::Pipeline& pipeline, ReplySink& out)
      : rt_(rt), pipeline_(pipeline), out_(out) {}

  //! Handles one request; replies at once, or later (detect) from tick() / result_sent().
  //! \param client who asked (replies go back to it)  \param r the request  \param now_us monotonic time
  void handle(int client, const Request& r, uint64_t now_us);
  //! Starts a detect that waited for the map. \param now_us monotonic time
  void tick(uint64_t now_us);
  //! A client went away: its waiting detects are dropped. \param client the client
  void client_closed(int client);
  //! Runtime::ResultListener: a new object list; waiting detects are answered.
  void result_sent(const runtime::ResultInfo& r) override;

  const StampedPoseHistory& flange_poses() const { return poses_; }
  //! runtime::FlangePoseSource: flange_poses() at stamp_us (the pipeline's robot poses).
  bool flange_pose_at(uint64_t stamp_us, Pose& T_base_flange) const override {
    return poses_.pose_at(stamp_us, T_base_flange);
  }
  const SessionCounters& counters() const { return counters_; }
  int objects_left() const;                 //!< objects NEXT would still offer
  int stations() const { return station_count_; }  //!< hand-eye stations held

 private:
  struct Pending {
    int client = -1;
    uint32_t id = 0;
    Command command = Command::kDetect;
  };
  Reply& begin(const Request& r);
  void send(int client);
  void record_pose(const Request& r, uint64_t now_us);
  bool need_pose(int client, const Request& r);
  void capture(int client, const Request& r);
  void detect(int client, const Request& r, uint64_t now_us);
  void detect_status(int client, const Request& r);
  bool start_detect(uint64_t now_us);
  void answer_detect(const Pending& p, const char* failure);
  void next(int client, const Request& r);
  void pick_result(int client, const Request& r);
  void status(int client, const Request& r);
  void hand_eye_add(int client, const Request& r);
  void hand_eye_solve(int client, const Request& r);
  //! The solve's per-station residuals and 1-sigma on stdout (edgefused's log).
  //! \param he a solved result
  static void print_hand_eye(const HandEyeResult& he);
  void hand_eye_save(int client, const Request& r);
  void calibration_get(int client, const Request& r);
  void fail(int client, const Request& r, ReplyStatus s, const char* why);

  runtime::Runtime& rt_;
  runtime::Pipeline& pipeline_;
  ReplySink& out_;
  Reply reply_;  // one reply at a time, encoded and sent at once
  SessionCounters counters_;
  StampedPoseHistory poses_;
  // Object list of the last result, picking order.
  runtime::ObjectResult objects_[runtime::kResultObjectsMax];
  bool gone_[runtime::kResultObjectsMax] = {};  // picked or failed
  int object_count_ = 0;
  int cursor_ = -1;   // the last offered object (NEXT continues after it)
  int offered_ = -1;  // the offered object a pick result refers to (-1: none)
  // Detect.
  Pending pending_[kPendingMax];
  int pending_count_ = 0;
  bool detect_wanted_ = false;   // a detect waits to start (map empty) or runs
  bool detect_started_ = false;  // the runtime localises for us
  uint64_t detect_since_us_ = 0;
  bool have_outcome_ = false;    // a detect finished: last_status_ / last_count_ hold its outcome
  ReplyStatus last_status_ = ReplyStatus::kNoObjects;
  uint32_t last_count_ = 0;
  const char* detect_failure_ = "";  // why the last detect could not start (the runtime's static text)
  // Hand-eye.
  Pose station_flange_[kHandEyeStationsMax];
  Pose station_camera_[kHandEyeStationsMax];
  int station_count_ = 0;
  HandEyeResult hand_eye_;
};

}  // namespace edgefuse::robot
