// Simulated depth cameras of the rig (bin_rig_a's noise models, README "Sensors and noise models"):
//   - structured light (Xtion-like): no return beyond 75 deg incidence, outside the range limits or
//     in projector shadow; axial noise sigma_z = 1.2 mm + 1.9 mm/m^2 (z - 0.4)^2 (Nguyen et al.);
//     disparity quantisation of 1/z in 0.0028 1/m steps; Lambertian registered colour;
//   - ToF (PMD-like): amplitude 20000 * refl * cos(incidence) * (0.5 m / r)^2 with 2% noise;
//     flying pixels (a depth jump > 3 cm to a 4-neighbour: probability 0.5 of a blend of both
//     depths); noise sigma_z = min(5 mm * z / sqrt(a_n), 2 cm); no return below a_n = 0.02.
// The rig moves on a slow horizontal circle above the bin (sim_rig_pose) so tracking has work, or
// along key poses (SimRigPath: stations for hand-eye calibration);
// the camera offers that motion and its mounting as simulator truth (TruthSource).
// Frames come at the mode's rate on the HAL clock (or as fast as possible when unpaced).
#pragma once

#include <cstdint>

#include "edgefuse/hal/clock.hpp"
#include "edgefuse/hal/depth_camera.hpp"
#include "edgefuse/hal/sim/sim_random.hpp"
#include "edgefuse/hal/sim/sim_rig_path.hpp"
#include "edgefuse/hal/sim/sim_scene.hpp"
#include "edgefuse/hal/truth_source.hpp"

namespace edgefuse::hal {

enum class SimDepthModel : uint8_t { kStructuredLight, kTof };

struct SimDepthCameraConfig {
  const char* name = "xtion";
  SimDepthModel model = SimDepthModel::kStructuredLight;
  PinholeIntrinsics intr;         //!< mode 0; mode 1 (structured light) doubles the resolution
  int fps = 30;                   //!< frame rate
  bool paced = true;              //!< false: as fast as possible (stamps still advance by 1/fps)
  Pose T_rig_cam;                 //!< mounting of this camera on the rig (xtion: identity)
  float rig_radius_m = 0.02f;     //!< radius of the rig's circular sway above the bin
  float rig_period_s = 8.0f;      //!< time for one circle
  const SimRigPath* rig_path = nullptr;  //!< when set, the rig follows these key poses instead (kept by pointer)
  uint64_t seed = 1;              //!< noise seed
  uint32_t start_offset_us = 0;   //!< stamp offset of the first frame (unsynchronised cameras)
};

//! bin_rig_a's xtion (320 x 240, depth_scale 5000, 0.4..3.5 m, colour).
SimDepthCameraConfig sim_xtion_config();
//! bin_rig_a's tof (160 x 120, depth_scale 5000, 0.1..1.5 m, amplitude), mounted as extrinsics.txt.
SimDepthCameraConfig sim_tof_config();
//! The rig (= xtion) pose over time: 0.70 m above the bin floor looking down, on a circle.
//! \param t_s time since the stream started  \param radius_m circle radius  \param period_s circle period
Pose sim_rig_pose(double t_s, float radius_m, float period_s);

class SimDepthCamera final : public DepthCamera, public TruthSource {
 public:
  static constexpr int kMaxWidth = 1280;  //!< widest mode (row buffers of the flying-pixel pass)

  //! \param config camera model and motion  \param scene what it sees (kept by reference)
  //! \param clock time base for stamps and pacing
  SimDepthCamera(const SimDepthCameraConfig& config, const SimScene& scene, Clock& clock);

  const char* name() const override { return config_.name; }
  int mode_count() const override;
  bool mode(int index, DepthMode& mode) const override;
  HalStatus start(int mode_index) override;
  void stop() override;
  PinholeIntrinsics intrinsics() const override { return intr_; }
  HalStatus next_frame(DepthFrame& frame, uint32_t timeout_ms) override;

  //! The camera model, its motion and its mounting on the rig.
  const SimDepthCameraConfig& config() const { return config_; }
  //! True camera-to-world pose of frame `sequence` (for tests and ground truth).
  //! \param sequence frame number since start
  Pose pose_of(uint32_t sequence) const;

  // TruthSource: the simulated rig's motion and this camera's mounting on it.
  //! pose_of(sequence); always true.
  bool pose_of(uint32_t sequence, Pose& T_world_cam) const override {
    T_world_cam = pose_of(sequence);
    return true;
  }
  //! The sim robot's flange (at the rig's origin): pose_of(sequence) * T_rig_cam^-1; always true.
  bool flange_pose_of(uint32_t sequence, Pose& T_world_flange) const override {
    T_world_flange = pose_of(sequence) * config_.T_rig_cam.inverse();
    return true;
  }
  //! config().T_rig_cam; always true.
  bool mounting(Pose& T_rig_cam) const override {
    T_rig_cam = config_.T_rig_cam;
    return true;
  }
  //! Runs the rig's motion on the clock from `epoch_us` on, shared by every camera of the rig, so
  //! that frames of different cameras with the same stamp see the rig at the same pose. Without it
  //! (0, the default) the motion starts at this camera's own start(): cameras started at different
  //! moments (each on its own acquisition thread) then see the rig displaced by the difference.
  //! \param epoch_us clock time of the rig's motion's t = 0 (set before start())
  void set_rig_epoch_us(uint64_t epoch_us) { rig_epoch_us_ = epoch_us; }
  //! Renders the frame at pose T_world_cam into `frame` (no pacing, no stamp).
  //! \param T_world_cam camera pose  \param frame storage (fits the mode)
  void render(const Pose& T_world_cam, DepthFrame& frame);

 private:
  void render_structured_light(const Pose& T, DepthFrame& f);
  void render_tof(const Pose& T, DepthFrame& f);

  SimDepthCameraConfig config_;
  const SimScene& scene_;
  Clock& clock_;
  SimRandom rng_;
  PinholeIntrinsics intr_;
  DepthMode mode_;
  bool running_ = false;
  uint64_t start_us_ = 0;
  uint64_t rig_epoch_us_ = 0;  // 0: the rig's motion starts at start()
  uint32_t sequence_ = 0;
  uint64_t last_stamp_us_ = 0;
  uint16_t row_prev_[kMaxWidth];
  uint16_t row_cur_[kMaxWidth];
};

}  // namespace edgefuse::hal
