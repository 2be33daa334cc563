// The processing pipeline as the runtime sees it (HAL frames -> filters -> tracking -> fusion ->
// localisation). edgefused drives it through this interface so the state machine, console and
// link are independent of how poses are produced: the HAL/fusion/localisation pipeline plugs in
// here; until then host-sim uses a simulated pose source (tools/edgefused/sim_pipeline.cpp).
// Calls must return quickly (the main loop also serves the console and the link).
#pragma once

#include <cstdint>

#include "edgefuse/link/messages.hpp"

namespace edgefuse::runtime {

struct PipelineStats {
  uint32_t frames = 0;  //!< frames processed since start
  uint32_t drops = 0;   //!< frames dropped since start
  float fps = 0;        //!< recent frame rate
  edgefuse_link_TrackingState tracking = edgefuse_link_TrackingState_TRACKING_OFF;
  uint64_t still_since_us = 0;  //!< when the rig stopped moving (0: moving or unknown)
};

class Pipeline {
 public:
  virtual ~Pipeline() = default;
  //! Starts tracking and pushing frames into the map. \return false with a reason in `why`
  virtual bool start_mapping(const char** why) = 0;
  virtual void stop_mapping() = 0;
  //! Empties the map (the next frames start a new one).
  virtual void reset_map() = 0;
  //! Does the work due now (grab, filter, track, integrate). Never blocks long.
  //! \param now_us monotonic time
  virtual void step(uint64_t now_us) = 0;
  //! Starts localisation on the current map. \return false with a reason in `why`
  virtual bool start_localization(uint64_t now_us, const char** why) = 0;
  //! True once the started localisation finished; fills `out` (objects, status, capture stamp;
  //! the runtime sets the sequence number).
  virtual bool poll_localization(link::LocalizationResult& out) = 0;
  //! Starts the rigid-pair calibration of `to` against the map of `from`. \return false + why
  virtual bool start_pair_calibration(const char* from, const char* to, const char** why) = 0;
  virtual PipelineStats stats() const = 0;
  virtual bool map_empty() const = 0;
  virtual int device_count() const = 0;
  virtual const char* device_name(int i) const = 0;
  virtual const char* device_state(int i) const = 0;
  virtual int model_count() const = 0;
  virtual const char* model_name(int i) const = 0;
};

}  // namespace edgefuse::runtime
