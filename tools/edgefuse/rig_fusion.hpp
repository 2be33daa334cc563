// A rig set's sensors mapped through the pipeline's Mapper (`edgefuse fuse --sensors`,
// `edgefuse localize --sensors`, `edgefuse calibrate`): each pinhole camera's recording bound to
// its slot of the board's static buffers, the volume placed, every camera's frames mapped at
// their recorded (or mounted) poses, then the line scanners' profiles.
#pragma once

#include <string>
#include <vector>

#include "core_setup.hpp"
#include "edgefuse/io/dataset.hpp"
#include "edgefuse/io/rig.hpp"
#include "edgefuse/pipeline/mapper.hpp"
#include "laser_push.hpp"

namespace edgefuse::cli {

//! One pinhole sensor of a rig set: its recording, bound to its camera slot of the board's buffers.
struct RigCamera {
  io::DepthSequence seq;
  CameraSlot cam;
  int slot = 0;
  bool tof = false;  //!< has amplitude images: ToF filters and noise model
  std::vector<uint16_t> load_depth, load_amplitude;  //!< file staging (host I/O)
  std::vector<Rgb8> load_colour;

  //! Binds slot `slot` of the core's buffers (CameraSlot::bind), the error naming the sensor; the
  //! bilateral pre-filter is on for structured light.
  //! \param core carved buffers  \param bilateral_tof the bilateral pre-filter on a ToF camera too
  //! \param err why not
  bool bind(const CoreSetup& core, bool bilateral_tof, std::string& err);
  //! Reads frame i from its files; `frame` views the staging vectors.
  //! \param i frame index  \param with_colour also its colour image, when it has one
  //! \param frame the frame as the pipeline takes it  \param err the file's error
  bool load(std::size_t i, bool with_colour, SensorFrame& frame, std::string& err);
  float median_sigma() const { return cam.median_sigma(); }
};

//! Index of the frame of `seq` whose stamp is nearest to stamp_s (within 0.02 s), or -1.
int frame_near(const io::DepthSequence& seq, double stamp_s);

//! The listed sensors of a rig set, opened for fusion (host I/O side).
struct RigSensors {
  std::vector<RigCamera> cams;      //!< pinhole sensors in listed order
  std::vector<io::LineScan> scans;  //!< line scanners in listed order
  std::vector<int> scan_slot;       //!< board slot of each scan
  int ref = -1;                     //!< reference camera: the first listed with colour, else the first pinhole
  int listed = 0;                   //!< number of listed sensors
};

//! Splits "a,b,c" at commas.
std::vector<std::string> split_names(const std::string& s);

//! Opens the listed sensors of the rig set in `folder`.
//! \param folder rig set folder  \param set its rig.toml  \param names sensor names (distinct, known)
//! \param board capacities (slot count)  \param rs opened sensors  \param err error text
//! \param usage set when the error is in the option (exit code 2) rather than in the data
bool open_rig_sensors(const std::string& folder, const io::RigSet& set, const std::vector<std::string>& names,
                      const BoardCapacities& board, RigSensors& rs, std::string& err, bool& usage);

//! Binds every camera to its slot and picks the filters' intermediate image: the depth buffer of a
//! slot no camera uses.
//! \param rs opened sensors  \param core set-up core buffers  \param bilateral_tof the bilateral
//! filter on ToF cameras too  \param filter_scratch the spare image  \param err error text
bool bind_rig_sensors(RigSensors& rs, CoreSetup& core, bool bilateral_tof, ImageView<uint16_t>& filter_scratch,
                      std::string& err);

//! Centres the volume on the reference camera's first view (or on the line scanner's returns).
//! \param rs opened sensors  \param settings volume settings (origin written)  \param err error text
bool place_rig_volume(RigSensors& rs, FuseSettings& settings, std::string& err);

//! Starts `mapper` on the core's placed volume with every camera of the set fused.
//! \param rs bound sensors  \param core core with the volume made  \param runners kernel threads
//! \param filter_scratch spare image  \param params pose mode (known), filters, weights, rules
//! \param mapper the mapper  \param err error text
bool start_rig_mapper(RigSensors& rs, CoreSetup& core, const KernelRunners& runners, ImageView<uint16_t> filter_scratch,
                      const MapperParams& params, Mapper& mapper, std::string& err);

//! The set's sub-unit fill (fusion_rules.hpp default_sub_unit_fill), decided before the push from
//! each camera's first frame as the mapper measures it, then fixed in the mapper.
//! \param rs bound sensors  \param mapper started mapper (noise weights on)  \param fill the fill set
//! \param err error text
bool plan_sub_unit_fill(RigSensors& rs, Mapper& mapper, int& fill, std::string& err);

//! Where each camera is mapped: at its own recorded poses, or at the reference camera's recorded
//! pose of the same instant times its mounting.
struct RigMounting {
  std::vector<Pose> T_ref_cam;  //!< the mounting of each camera (where mounted)
  std::vector<char> mounted;    //!< 1: placed by T_ref_cam
};

//! Maps every camera's frames (camera after camera), then every line scanner's profiles (own poses).
//! \param rs bound sensors  \param mapper started mapper  \param core the core (line scanners' tables)
//! \param mounting poses of the cameras  \param frames_max frames per camera
//! \param colour_ref integrate the reference camera's colour  \param err error text
//! \param verbose one line per sensor  \param laser line scanners: patch registration (laser_push.hpp)
bool push_rig_frames(RigSensors& rs, Mapper& mapper, CoreSetup& core, const RigMounting& mounting,
                     std::size_t frames_max, bool colour_ref, std::string& err, bool verbose,
                     const LaserPushOptions& laser = LaserPushOptions());

}  // namespace edgefuse::cli
