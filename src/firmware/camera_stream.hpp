// One depth camera of edgefused as the pipeline sees it: its acquisition thread (hal/acquisition
// CameraWorker: stall -> reopen with back-off, unplug -> wait for the DeviceMonitor, sanity checks
// with counted reasons), the fixed pool of frames it fills (its sensor slot's pool in the board's
// memory map: regions "acquisition pools: ..."; SPSC rings), the
// newest frame the pipeline holds, and the camera's slot of the board's per-sensor buffers
// (filtered depth, trust map, ray norms, raycast maps, tile scratch, pyramid, ICP rows) with its
// pre-filters and noise model.
//
// Newest-frame policy: take_newest() (the reference camera) swaps the held frame for the newest
// ready one; older ready frames go back to the device unread (counted as dropped_stale by the
// channel), and a held frame that was never processed counts as skipped. The other cameras are
// paired with the reference's frame by nearest stamp (take_nearest()).
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "edgefuse/memory/memmap.hpp"
#include "edgefuse/pipeline/camera_slot.hpp"
#include "edgefuse/hal/acquisition/acquisition_counters.hpp"
#include "edgefuse/hal/acquisition/camera_worker.hpp"
#include "edgefuse/hal/acquisition/frame_channel.hpp"
#include "edgefuse/hal/acquisition/frame_pool.hpp"

namespace edgefuse::firmware {

struct CameraStream {
  std::string name;             //!< hal.toml name
  int index = -1;               //!< camera index in hal.toml (= the board's sensor slot)
  bool fuse = false;            //!< integrated into the map (sensors.fuse)
  CameraSlot slot;              //!< its slot of the board's per-sensor buffers, filters, noise model
  hal::AcquisitionCounters counters;
  hal::FrameChannel channel;
  std::unique_ptr<hal::CameraWorker> worker;
  const hal::DepthFrame* held = nullptr;  //!< newest frame taken from the channel (null: none yet)
  bool held_new = false;                  //!< held and not processed yet
  uint64_t paired_stamp_us = 0;           //!< the reference frame the held frame was paired with
  uint32_t skipped = 0;                   //!< held frames replaced before they were processed
  uint32_t integrated = 0;                //!< frames integrated into the map
  uint32_t unpaired = 0;                  //!< no reference pose within the pairing window

  // Extrinsics: pose of this camera in the reference camera's frame (T_ref_cam).
  Pose T_ref_cam;
  bool has_mount = false;
  const char* mount_source = "none";

  //! Start-up: binds the slot's buffers, filters and pool.
  //! \param buffers the carved arena  \param board capacities  \param intr the camera
  //! \param tof amplitude images: ToF filters and noise model  \param bilateral bilateral filter on
  //! \param err names the camera
  bool bind(CoreBuffers& buffers, const BoardCapacities& board, const PinholeIntrinsics& intr, bool tof,
            bool bilateral, std::string& err);
  //! Empties the pool (its thread must be stopped; the held frame is dropped).
  bool restart_pool();
  //! Swaps the held frame for the newest ready one. \return true when a new frame is held
  bool take_newest();
  //! Swaps the held frame for the ready one nearest in time to stamp_us when that is nearer than
  //! the held one (a camera paired with the reference). \return true when a new frame is held
  //! \param stamp_us the reference frame's stamp
  bool take_nearest(uint64_t stamp_us);
  //! Returns the held frame to the channel (before the worker restarts the pool).
  void release_held();
  //! The held frame as the pipeline takes it.
  SensorFrame held_frame() const;
  //! "state=.. frames=.. ..." for the status command (static text per stream, no heap).
  const char* status_text() const;

 private:
  mutable char status_[480] = {};
  const FramePoolBuffers* pools_ = nullptr;  // the carved memory map's frame pools
  hal::FramePoolViews pool_views_;           // this camera's frames in them
};

}  // namespace edgefuse::firmware
