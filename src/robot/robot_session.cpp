#include "edgefuse/robot/robot_session.hpp"

#include <cmath>
#include <cstdio>

#include "edgefuse/runtime/calib_pose.hpp"

namespace edgefuse::robot {

namespace {

void copy_text(char* out, const char* in) {
  std::snprintf(out, kReplyMessageMax + 1, "%s", in != nullptr ? in : "");
}

bool localizing(runtime::RuntimeState s) {
  return s == runtime::RuntimeState::kLocalize || s == runtime::RuntimeState::kReport;
}

}  // namespace

Reply& RobotSession::begin(const Request& r) {
  reply_ = Reply();
  reply_.id = r.id;
  reply_.command = r.command;
  return reply_;
}

void RobotSession::send(int client) {
  ++counters_.replies;
  out_.reply(client, reply_);
}

void RobotSession::fail(int client, const Request& r, ReplyStatus s, const char* why) {
  begin(r).status = s;
  copy_text(reply_.message, why);
  send(client);
}

// A pose without a stamp is stamped when received; poses that arrive together (a burst in one
// read) keep their order 1 us apart rather than being refused as not newer.
void RobotSession::record_pose(const Request& r, uint64_t now_us) {
  if (!r.has_pose) return;
  uint64_t stamp_us = r.stamp_us;
  Pose newest;
  uint64_t newest_us = 0;
  if (stamp_us == 0) stamp_us = poses_.newest(newest, newest_us) && newest_us >= now_us ? newest_us + 1 : now_us;
  if (!poses_.record(stamp_us, r.T_base_flange)) ++counters_.poses_refused;
}

// A request that must carry the flange pose and does not: answered kBadRequest.
bool RobotSession::need_pose(int client, const Request& r) {
  if (r.has_pose) return true;
  ++counters_.bad_requests;
  fail(client, r, ReplyStatus::kBadRequest, "the flange pose is missing");
  return false;
}

void RobotSession::handle(int client, const Request& r, uint64_t now_us) {
  ++counters_.requests;
  switch (r.command) {
    case Command::kNone:
      ++counters_.bad_requests;
      fail(client, r, ReplyStatus::kBadRequest, r.error != nullptr ? r.error : "unreadable request");
      return;
    case Command::kPose:
      ++counters_.pose_updates;
      if (need_pose(client, r)) record_pose(r, now_us);
      return;  // streamed: no reply
    case Command::kCapture:
      if (need_pose(client, r)) {
        record_pose(r, now_us);
        capture(client, r);
      }
      return;
    case Command::kStop:
      rt_.scan(false);
      begin(r);
      send(client);
      return;
    case Command::kDetect:
    case Command::kDetectAsync:
      record_pose(r, now_us);
      detect(client, r, now_us);
      return;
    case Command::kDetectStatus: detect_status(client, r); return;
    case Command::kNext: next(client, r); return;
    case Command::kPickResult: pick_result(client, r); return;
    case Command::kStatus: status(client, r); return;
    case Command::kHandEyeAdd:
      if (need_pose(client, r)) {
        record_pose(r, now_us);
        hand_eye_add(client, r);
      }
      return;
    case Command::kHandEyeSolve: hand_eye_solve(client, r); return;
    case Command::kHandEyeSave: hand_eye_save(client, r); return;
    case Command::kHandEyeReset:
      station_count_ = 0;
      hand_eye_ = HandEyeResult();
      begin(r);
      send(client);
      return;
    case Command::kCalibrationGet: calibration_get(client, r); return;
    case Command::kUnknown: break;
  }
  ++counters_.unknown_commands;
  fail(client, r, ReplyStatus::kUnknownCommand, "unknown command");
}

// A new capture is a new bin: the map starts afresh (the objects picked since the last one are gone).
void RobotSession::capture(int client, const Request& r) {
  if (localizing(rt_.state())) return fail(client, r, ReplyStatus::kBusy, "localising: wait for the result");
  const runtime::CmdResult reset = rt_.map_reset();
  const runtime::CmdResult started = reset.code == runtime::ConsoleError::kOk ? rt_.scan(true) : reset;
  if (started.code != runtime::ConsoleError::kOk) return fail(client, r, ReplyStatus::kFailed, started.message);
  begin(r);
  send(client);
}

void RobotSession::detect(int client, const Request& r, uint64_t now_us) {
  if (r.command == Command::kDetect) {
    if (pending_count_ == kPendingMax) return fail(client, r, ReplyStatus::kBusy, "too many detects waiting");
    pending_[pending_count_++] = Pending{client, r.id, r.command};
  }
  if (!detect_wanted_) {
    detect_wanted_ = true;
    detect_started_ = false;
    detect_since_us_ = now_us;
    have_outcome_ = false;
  }
  if (!detect_started_ && !start_detect(now_us)) {  // failed: every waiting detect was told
    if (r.command == Command::kDetectAsync) fail(client, r, ReplyStatus::kFailed, detect_failure_);
    return;
  }
  if (r.command == Command::kDetectAsync) {
    begin(r).status = ReplyStatus::kOk;
    send(client);
  }
}

// \return false when the detect failed (and was answered)
bool RobotSession::start_detect(uint64_t now_us) {
  const runtime::RuntimeState s = rt_.state();
  if (localizing(s)) {  // someone else's localisation: its result answers ours
    detect_started_ = true;
    return true;
  }
  // Right after CAPTURE the first frames may not have reached the map yet.
  if (s == runtime::RuntimeState::kMapping && pipeline_.map_empty() && now_us - detect_since_us_ < kMapWaitUs)
    return true;
  const runtime::CmdResult c = rt_.localize();
  if (c.code == runtime::ConsoleError::kOk) {
    detect_started_ = true;
    return true;
  }
  detect_wanted_ = false;
  have_outcome_ = true;
  last_status_ = ReplyStatus::kFailed;
  last_count_ = 0;
  detect_failure_ = c.message;
  for (int i = 0; i < pending_count_; ++i) answer_detect(pending_[i], c.message);
  pending_count_ = 0;
  return false;
}

void RobotSession::tick(uint64_t now_us) {
  if (detect_wanted_ && !detect_started_) start_detect(now_us);
}

void RobotSession::answer_detect(const Pending& p, const char* failure) {
  reply_ = Reply();
  reply_.id = p.id;
  reply_.command = p.command;
  reply_.status = last_status_;
  reply_.count = last_count_;
  copy_text(reply_.message, failure);
  send(p.client);
}

void RobotSession::result_sent(const runtime::ResultInfo& r) {
  object_count_ = 0;
  for (int i = 0; i < r.count && i < runtime::kResultObjectsMax; ++i) {
    objects_[object_count_] = r.objects[i];
    gone_[object_count_++] = false;
  }
  cursor_ = -1;
  offered_ = -1;
  have_outcome_ = true;
  last_count_ = uint32_t(object_count_);
  last_status_ = r.status == runtime::ResultStatus::kFailed ? ReplyStatus::kFailed
                 : object_count_ == 0                         ? ReplyStatus::kNoObjects
                                                              : ReplyStatus::kOk;
  detect_wanted_ = false;
  detect_started_ = false;
  const char* why = last_status_ == ReplyStatus::kFailed ? "localisation failed" : "";
  for (int i = 0; i < pending_count_; ++i) answer_detect(pending_[i], why);
  pending_count_ = 0;
}

void RobotSession::client_closed(int client) {
  int kept = 0;
  for (int i = 0; i < pending_count_; ++i)
    if (pending_[i].client != client) pending_[kept++] = pending_[i];
  pending_count_ = kept;
}

void RobotSession::detect_status(int client, const Request& r) {
  Reply& out = begin(r);
  if (detect_wanted_) {
    out.status = ReplyStatus::kRunning;
  } else if (!have_outcome_) {
    out.status = ReplyStatus::kNoObjects;
    copy_text(out.message, "no detect yet");
  } else {
    out.status = last_status_;
    out.count = last_count_;
  }
  send(client);
}

int RobotSession::objects_left() const {
  int n = 0;
  for (int i = cursor_ + 1; i < object_count_; ++i) n += !gone_[i];
  return n;
}

void RobotSession::next(int client, const Request& r) {
  if (detect_wanted_) return fail(client, r, ReplyStatus::kBusy, "detect running");
  int i = cursor_ + 1;
  while (i < object_count_ && gone_[i]) ++i;
  Reply& out = begin(r);
  if (i >= object_count_) {
    out.status = ReplyStatus::kNoObjects;
    return send(client);
  }
  cursor_ = offered_ = i;
  out.has_object = true;
  out.object = objects_[i];
  out.T_base_grasp = objects_[i].T_world_object;  // no grasp planner yet: the gripper goes to the object's pose
  out.left = uint32_t(objects_left());
  send(client);
}

void RobotSession::pick_result(int client, const Request& r) {
  if (offered_ < 0) return fail(client, r, ReplyStatus::kBadRequest, "no object offered (NEXT first)");
  gone_[offered_] = true;
  offered_ = -1;
  begin(r).left = uint32_t(objects_left());
  send(client);
}

void RobotSession::status(int client, const Request& r) {
  Reply& out = begin(r);
  out.state = rt_.state();
  out.tracking = pipeline_.stats().tracking;
  out.left = uint32_t(objects_left());
  out.count = uint32_t(object_count_);
  out.stations = uint32_t(station_count_);
  send(client);
}

void RobotSession::hand_eye_add(int client, const Request& r) {
  if (station_count_ == kHandEyeStationsMax)
    return fail(client, r, ReplyStatus::kBusy, "station list full: HANDEYE SOLVE or RESET");
  Pose T_map_rig;
  uint64_t stamp_us = 0;
  if (!pipeline_.rig_pose(T_map_rig, stamp_us))
    return fail(client, r, ReplyStatus::kFailed, "no camera pose: CAPTURE first, hold still, keep tracking");
  station_flange_[station_count_] = r.T_base_flange;
  station_camera_[station_count_++] = T_map_rig;
  begin(r).count = uint32_t(station_count_);
  send(client);
}

// The reply holds the RMS only; the log names the station that disagrees (a tracking slip at a
// move shows as one large residual) and the result's 1-sigma.
void RobotSession::print_hand_eye(const HandEyeResult& he) {
  constexpr double kDeg = 180.0 / 3.14159265358979;
  for (int i = 0; i < he.stations; ++i)
    std::printf("handeye: station %d residual %.3f mm %.4f deg\n", i + 1, 1000.0 * double(he.station_residual_m[i]),
                double(he.station_residual_deg[i]));
  std::printf("handeye: %d stations, %d pairs, pair rms %.3f mm %.4f deg, 1-sigma rot %.4f %.4f %.4f deg trans %.3f %.3f "
              "%.3f mm\n",
              he.stations, he.pairs, 1000.0 * double(he.rms_translation_m), double(he.rms_rotation_deg),
              kDeg * double(he.sigma[0]), kDeg * double(he.sigma[1]), kDeg * double(he.sigma[2]),
              1000.0 * double(he.sigma[3]), 1000.0 * double(he.sigma[4]), 1000.0 * double(he.sigma[5]));
  std::fflush(stdout);
}

void RobotSession::hand_eye_solve(int client, const Request& r) {
  hand_eye_ = HandEyeResult();
  if (station_count_ < 3) {  // the solver says so too, in more words than a reply holds
    char why[kReplyMessageMax + 1];
    std::snprintf(why, sizeof(why), "%d stations: at least 3, rotated about 2 axes", station_count_);
    return fail(client, r, ReplyStatus::kNotCalibrated, why);
  }
  if (solve_hand_eye(station_flange_, station_camera_, station_count_, HandEyeParams(), hand_eye_) != Status::kOk ||
      !hand_eye_.solved)
    return fail(client, r, ReplyStatus::kNotCalibrated,
                hand_eye_.reason[0] != '\0' ? hand_eye_.reason : "the stations do not determine the mounting");
  print_hand_eye(hand_eye_);
  Reply& out = begin(r);
  double sum_m = 0, sum_deg = 0;
  for (int i = 0; i < hand_eye_.stations; ++i) {
    sum_m += double(hand_eye_.station_residual_m[i]) * double(hand_eye_.station_residual_m[i]);
    sum_deg += double(hand_eye_.station_residual_deg[i]) * double(hand_eye_.station_residual_deg[i]);
  }
  const double n = hand_eye_.stations > 0 ? double(hand_eye_.stations) : 1.0;
  out.has_hand_eye = true;
  out.T_flange_camera = hand_eye_.T_flange_cam;
  out.residual_mm = float(1000.0 * std::sqrt(sum_m / n));
  out.residual_deg = float(std::sqrt(sum_deg / n));
  out.count = uint32_t(hand_eye_.stations);
  send(client);
}

void RobotSession::hand_eye_save(int client, const Request& r) {
  if (!hand_eye_.solved) return fail(client, r, ReplyStatus::kNotCalibrated, "not solved: HANDEYE SOLVE first");
  const Eigen::Quaternionf q = hand_eye_.T_flange_cam.quaternion();
  const Vec3f& t = hand_eye_.T_flange_cam.t;
  const float tq[7] = {t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w()};
  runtime::CmdResult c = rt_.calib_set("flange", tq);
  if (c.code == runtime::ConsoleError::kOk) c = rt_.calib_save();
  if (c.code != runtime::ConsoleError::kOk) return fail(client, r, ReplyStatus::kFailed, c.message);
  begin(r);
  send(client);
}

void RobotSession::calibration_get(int client, const Request& r) {
  const runtime::CalibPose& p = rt_.calibration().T_flange_rig;
  Reply& out = begin(r);
  out.has_hand_eye = true;
  out.T_flange_camera = runtime::to_pose(p);
  // The stored default is the identity: no hand-eye calibration has been saved.
  if (runtime::is_default(p)) {
    out.status = ReplyStatus::kNotCalibrated;
    copy_text(out.message, "no hand-eye calibration stored");
  }
  send(client);
}

}  // namespace edgefuse::robot
