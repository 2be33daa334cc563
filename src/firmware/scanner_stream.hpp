// The board's line scanner in edgefused: its acquisition thread (hal/acquisition ScannerWorker:
// one profile per trigger edge, checks, reopen with back-off), the fixed pool of profiles it fills
// (the memory map's region "acquisition pools: line profiles"; SPSC rings; processing drains every
// profile: each is one slice of the scan),
// and what integration needs: the scanner model, its tan(theta) table in the board's per-sensor
// buffers, and the axis that carries it (a profile's pose is T_world_axis0 moved along the axis by
// the profile's axis position).
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "edgefuse/memory/memmap.hpp"
#include "edgefuse/sensor/line_scanner.hpp"
#include "edgefuse/hal/acquisition/acquisition_counters.hpp"
#include "edgefuse/hal/acquisition/frame_channel.hpp"
#include "edgefuse/hal/acquisition/frame_pool.hpp"
#include "edgefuse/hal/acquisition/scanner_worker.hpp"

namespace edgefuse::firmware {

struct ScannerStream {
  std::string name;        //!< hal.toml name ("" : the board has no line scanner)
  int slot = -1;           //!< the board's sensor slot of its table
  bool fuse = false;       //!< integrated into the map (sensors.fuse)
  LineScannerModel model;
  LineScannerTables<real_t> tables;
  bool has_axis = false;
  Pose T_world_axis0;      //!< the sensor's pose at axis position 0
  Vec3f axis_world = Vec3f::UnitY();
  hal::AcquisitionCounters counters;
  hal::ProfileChannel channel;
  std::unique_ptr<hal::ScannerWorker> worker;
  uint32_t integrated = 0;  //!< profiles integrated into the map
  uint32_t skipped = 0;     //!< profiles of a map scanner that could not be placed (no map yet, no position)

  //! Start-up: model, table, pool and thread object.
  //! \param scanner the device  \param buffers the carved arena  \param board capacities
  //! \param slot_index its sensor slot  \param err names the scanner
  bool bind(hal::LineScanner& scanner, CoreBuffers& buffers, const BoardCapacities& board, int slot_index,
            std::string& err);
  //! Empties the pool (its thread must be stopped).
  bool restart_pool();
  //! The profile's sensor-to-world pose. \return false without axis or position
  //! \param p the profile  \param T_world_sensor receives the pose
  bool pose_of(const hal::LineProfile& p, Pose& T_world_sensor) const {
    if (!has_axis || !p.has_position) return false;
    T_world_sensor = T_world_axis0;
    T_world_sensor.t += float(p.axis_position_m) * axis_world;
    return true;
  }
  //! Status lines ('\n'-separated) for the status command.
  const char* status_text() const;

 private:
  mutable char status_[400] = {};
  const ProfilePoolBuffers* pool_ = nullptr;  // the carved memory map's profile pool
  hal::ProfilePoolViews pool_views_;          // its profiles
  int beams_ = 0;                             // the scanner's beams per profile
};

}  // namespace edgefuse::firmware
