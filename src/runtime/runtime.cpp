#include "edgefuse/runtime/runtime.hpp"

#include <cstdio>
#include <cstring>

namespace edgefuse::runtime {

const char* to_string(RuntimeState s) {
  switch (s) {
    case RuntimeState::kIdle: return "IDLE";
    case RuntimeState::kMapping: return "MAPPING";
    case RuntimeState::kLocalize: return "LOCALIZE";
    case RuntimeState::kReport: return "REPORT";
  }
  return "?";
}

namespace {

const char* tracking_text(TrackingState t) {
  switch (t) {
    case TrackingState::kOff: return "off";
    case TrackingState::kOk: return "ok";
    case TrackingState::kDegraded: return "degraded";
    case TrackingState::kLost: return "lost";
  }
  return "?";
}

void print_pose(ConsoleWriter& out, const char* what, const CalibPose& p) {
  out.line("%s: t %.4f %.4f %.4f q %.5f %.5f %.5f %.5f", what, double(p.tq[0]), double(p.tq[1]), double(p.tq[2]),
           double(p.tq[3]), double(p.tq[4]), double(p.tq[5]), double(p.tq[6]));
}

}  // namespace

void Runtime::send_heartbeat(uint64_t now_us) {
  const PipelineStats st = pipeline_.stats();
  HeartbeatInfo h;
  h.seq = heartbeat_seq_++;
  h.stamp_us = now_us;
  h.state = state_;
  h.tracking = st.tracking;
  h.fps = st.fps;
  h.frames = st.frames;
  h.drops = st.drops;
  h.results = result_seq_;
  h.uptime_s = uint32_t((now_us - start_us_) / 1000000u);
  out_.publish(h);
}

// Drops objects below the score threshold, numbers the result, sends it.
void Runtime::send_result() {
  const float min_score = float(params_.get_number(kLocalizeMinScore));
  int kept = 0;
  for (int i = 0; i < result_.count; ++i)
    if (result_.objects[i].score >= min_score) result_.objects[kept++] = result_.objects[i];
  result_.count = kept;
  ResultInfo r;
  r.seq = result_seq_++;
  r.stamp_us = result_.stamp_us;
  r.status = result_.failed ? ResultStatus::kFailed : kept == 0 ? ResultStatus::kNoObjects : ResultStatus::kOk;
  r.objects = result_.objects;
  r.count = kept;
  if (listener_ != nullptr) listener_->result_sent(r);
  for (int i = 0; i < params_.get_int(kReportRepeat); ++i) out_.publish(r);
}

bool Runtime::begin_localize(uint64_t now_us, const char** why) {
  if (!pipeline_.start_localization(now_us, why)) return false;
  result_ = LocalizationOutcome();
  result_.stamp_us = now_us;
  state_ = RuntimeState::kLocalize;
  return true;
}

void Runtime::tick(uint64_t now_us) {
  if (start_us_ == 0) {
    start_us_ = now_us;
    next_heartbeat_us_ = now_us;
  }
  now_us_ = now_us;
  pipeline_.step(now_us);

  switch (state_) {
    case RuntimeState::kIdle: break;
    case RuntimeState::kMapping: {
      // Still-period trigger: once per still period; re-armed when the rig moves again.
      const PipelineStats st = pipeline_.stats();
      const double period_s = params_.get_number(kLocalizeStillPeriodS);
      if (st.still_since_us == 0) still_armed_ = true;
      if (period_s > 0 && still_armed_ && st.still_since_us != 0 &&
          now_us - st.still_since_us >= uint64_t(period_s * 1e6) && !pipeline_.map_empty()) {
        const char* why = "";
        still_armed_ = false;
        begin_localize(now_us, &why);
      }
      break;
    }
    case RuntimeState::kLocalize:
      if (pipeline_.poll_localization(result_)) state_ = RuntimeState::kReport;
      break;
    case RuntimeState::kReport: {
      send_result();
      state_ = scanning_ ? RuntimeState::kMapping : RuntimeState::kIdle;
      if (!scanning_) pipeline_.stop_mapping();
      break;
    }
  }

  if (now_us >= next_heartbeat_us_) {
    send_heartbeat(now_us);
    next_heartbeat_us_ = now_us + uint64_t(params_.get_int(kLinkHeartbeatMs)) * 1000u;
  }
}

CmdResult Runtime::status(ConsoleWriter& out) {
  const PipelineStats st = pipeline_.stats();
  out.line("state %s%s", to_string(state_), scanning_ ? " (scanning)" : "");
  out.line("fps %.1f frames %u drops %u", double(st.fps), unsigned(st.frames), unsigned(st.drops));
  out.line("tracking %s", tracking_text(st.tracking));
  out.line("results %u heartbeats %u map %s", unsigned(result_seq_), unsigned(heartbeat_seq_),
           pipeline_.map_empty() ? "empty" : "filled");
  // A device's state may run over several lines ('\n'): the first follows its name, the rest indent.
  for (int i = 0; i < pipeline_.device_count(); ++i) {
    const char* s = pipeline_.device_state(i);
    const char* nl = std::strchr(s, '\n');
    out.line("device %s %.*s", pipeline_.device_name(i), int(nl ? nl - s : int(std::strlen(s))), s);
    while (nl != nullptr) {
      s = nl + 1;
      nl = std::strchr(s, '\n');
      out.line("  %.*s", int(nl ? nl - s : int(std::strlen(s))), s);
    }
  }
  return CmdResult::ok();
}

CmdResult Runtime::calib_fuse(const char* from, const char* to, ConsoleWriter& out) {
  if (state_ == RuntimeState::kLocalize || state_ == RuntimeState::kReport)
    return CmdResult::error(ConsoleError::kWrongState, "localising: wait for the result");
  const char* why = "";
  PairCalibrationReport r;
  if (!pipeline_.calibrate_pair(from, to, r, &why)) return CmdResult::error(ConsoleError::kFailed, why);
  if (!calib_set_pair(calib_, from, to, r.T_from_to))
    return CmdResult::error(ConsoleError::kFailed, "calibration table full");
  char what[48];
  std::snprintf(what, sizeof(what), "T_%s_%s", from, to);
  print_pose(out, what, r.T_from_to);
  out.line("uncertainty (1 sigma, %s frame): rot %.4f %.4f %.4f deg, trans %.3f %.3f %.3f mm", to,
           double(r.sigma_rot_deg[0]), double(r.sigma_rot_deg[1]), double(r.sigma_rot_deg[2]),
           double(r.sigma_trans_mm[0]), double(r.sigma_trans_mm[1]), double(r.sigma_trans_mm[2]));
  out.line("fit: rms %.2f mm, inliers %.2f, %d correspondences; %.2f mm / %.3f deg from the guess (%s)",
           double(r.rms_mm), double(r.inlier_ratio), r.correspondences, double(r.moved_mm), double(r.moved_deg),
           r.guess_source);
  out.line("frames averaged: %d; one frame scatters by rot %.4f %.4f %.4f deg, trans %.3f %.3f %.3f mm", r.frames,
           double(r.spread_rot_deg[0]), double(r.spread_rot_deg[1]), double(r.spread_rot_deg[2]),
           double(r.spread_trans_mm[0]), double(r.spread_trans_mm[1]), double(r.spread_trans_mm[2]));
  pipeline_.calibration_changed(calib_);
  // Persisted at once (as `calib save`): a calibration worth running is worth keeping.
  if (!storage_.save(calib_, text_, sizeof(text_))) return CmdResult::error(ConsoleError::kStorage, text_);
  out.line("saved");
  return CmdResult::ok();
}

CmdResult Runtime::calib_show(ConsoleWriter& out) {
  char what[64];
  if (calib_.pair_count == 0) out.line("no sensor pairs calibrated");
  for (int i = 0; i < calib_.pair_count; ++i) {
    std::snprintf(what, sizeof(what), "T_%s_%s", calib_.pairs[i].from, calib_.pairs[i].to);
    print_pose(out, what, calib_.pairs[i].T_from_to);
  }
  for (int i = 0; i < calib_.intrinsic_count; ++i) {
    const IntrinsicOverride& k = calib_.intrinsics[i];
    out.line("intrinsics %s: fx %.3f fy %.3f cx %.3f cy %.3f", k.sensor, double(k.fx), double(k.fy), double(k.cx),
             double(k.cy));
  }
  print_pose(out, "T_flange_rig (hand-eye)", calib_.T_flange_rig);
  print_pose(out, "T_world_bin", calib_.T_world_bin);
  return CmdResult::ok();
}

CmdResult Runtime::calib_set(const char* sensor, const float tq[7]) {
  CalibPose p;
  std::memcpy(p.tq, tq, sizeof(p.tq));
  // Two names that are not sensors: the rig on the flange (hand-eye) and the bin in the world.
  if (!std::strcmp(sensor, "flange")) {
    calib_.T_flange_rig = p;
    pipeline_.calibration_changed(calib_);
    return CmdResult::ok();
  }
  if (!std::strcmp(sensor, "bin")) {
    calib_.T_world_bin = p;
    return CmdResult::ok();
  }
  bool known = false;
  for (int i = 0; i < pipeline_.device_count(); ++i) known |= !std::strcmp(pipeline_.device_name(i), sensor);
  if (!known) {
    std::snprintf(text_, sizeof(text_), "no sensor '%.40s' on this rig (status lists them; or flange, bin)", sensor);
    return CmdResult::error(ConsoleError::kNotFound, text_);
  }
  if (!calib_set_pair(calib_, "rig", sensor, p))
    return CmdResult::error(ConsoleError::kFailed, "calibration table full");
  pipeline_.calibration_changed(calib_);
  return CmdResult::ok();
}

CmdResult Runtime::calib_intrinsics(const char* sensor, const float k[4]) {
  bool known = false;
  for (int i = 0; i < pipeline_.device_count(); ++i) known |= !std::strcmp(pipeline_.device_name(i), sensor);
  if (!known || std::strlen(sensor) > kSensorNameMax) {
    std::snprintf(text_, sizeof(text_), "no sensor '%.40s' on this rig (status lists them)", sensor);
    return CmdResult::error(ConsoleError::kNotFound, text_);
  }
  IntrinsicOverride* o = nullptr;
  for (int i = 0; i < calib_.intrinsic_count; ++i)
    if (!std::strcmp(calib_.intrinsics[i].sensor, sensor)) o = &calib_.intrinsics[i];
  if (o == nullptr) {
    if (calib_.intrinsic_count >= kCalibIntrinsicsMax)
      return CmdResult::error(ConsoleError::kFailed, "intrinsics table full");
    o = &calib_.intrinsics[calib_.intrinsic_count++];
    *o = IntrinsicOverride{};
    std::memcpy(o->sensor, sensor, std::strlen(sensor) + 1);
  }
  o->fx = k[0];
  o->fy = k[1];
  o->cx = k[2];
  o->cy = k[3];
  return CmdResult::ok();
}

CmdResult Runtime::calib_save() {
  if (!storage_.save(calib_, text_, sizeof(text_))) return CmdResult::error(ConsoleError::kStorage, text_);
  return CmdResult::ok();
}

CmdResult Runtime::calib_load() {
  CalibrationData d;
  if (!storage_.load(d, text_, sizeof(text_))) return CmdResult::error(ConsoleError::kStorage, text_);
  calib_ = d;
  pipeline_.calibration_changed(calib_);
  return CmdResult::ok();
}

CmdResult Runtime::calib_reset() {
  calib_ = CalibrationData{};
  pipeline_.calibration_changed(calib_);
  return CmdResult::ok();
}

CmdResult Runtime::scan(bool start) {
  if (start) {
    if (state_ == RuntimeState::kIdle) {
      const char* why = "";
      if (!pipeline_.start_mapping(&why)) return CmdResult::error(ConsoleError::kFailed, why);
      state_ = RuntimeState::kMapping;
    }
    scanning_ = true;
    return CmdResult::ok();
  }
  scanning_ = false;
  if (state_ == RuntimeState::kMapping) {
    pipeline_.stop_mapping();
    state_ = RuntimeState::kIdle;
  }
  return CmdResult::ok();
}

CmdResult Runtime::map_reset() {
  if (state_ == RuntimeState::kLocalize || state_ == RuntimeState::kReport)
    return CmdResult::error(ConsoleError::kWrongState, "localising: wait for the result");
  pipeline_.reset_map();
  return CmdResult::ok();
}

CmdResult Runtime::localize() {
  if (state_ == RuntimeState::kLocalize || state_ == RuntimeState::kReport)
    return CmdResult::error(ConsoleError::kWrongState, "already localising");
  if (pipeline_.map_empty()) return CmdResult::error(ConsoleError::kWrongState, "the map is empty (scan start first)");
  const char* why = "";
  if (!begin_localize(now_us_, &why)) return CmdResult::error(ConsoleError::kFailed, why);
  return CmdResult::ok();
}

CmdResult Runtime::model_list(ConsoleWriter& out) {
  for (int i = 0; i < pipeline_.model_count(); ++i) out.line("%d %s", i + 1, pipeline_.model_name(i));
  if (pipeline_.model_count() == 0) out.line("no models loaded");
  return CmdResult::ok();
}

CmdResult Runtime::log_level(int) { return CmdResult::ok(); }  // the level lives in params (log.level)

CmdResult Runtime::param_changed(int id) {
  if (id == kLinkHeartbeatMs) next_heartbeat_us_ = now_us_;  // apply the new period at once
  return CmdResult::ok();
}

}  // namespace edgefuse::runtime
