// Start-up of the core for the host programs: carve the board's static arena, bind a volume,
// stage frames into the static frame buffers, extract results.
#pragma once

#include <string>
#include <vector>

#include "edgefuse/io/cloud.hpp"
#include "edgefuse/memory/arena.hpp"
#include "edgefuse/pipeline/camera_slot.hpp"
#include "edgefuse/pipeline/kernels.hpp"
#include "edgefuse/pipeline/view_centre.hpp"
#include "edgefuse/sensor/pinhole.hpp"
#include "edgefuse/tsdf/integrate.hpp"
#include "edgefuse/tsdf/raycast.hpp"
#include "edgefuse/tsdf/volume.hpp"
#include "edgefuse/hal/platform/threads/pool_row_runner.hpp"
#include "edgefuse/hal/platform/threads/worker_pool.hpp"

namespace edgefuse::cli {

struct FuseSettings {
  float voxel_m = 0.004f;
  float trunc_m = 0.016f;
  int max_weight = 255;
  int dim = 128;
  int threads = 1;
  Vec3f origin_m = Vec3f::Zero();
  bool origin_given = false;
  // Which settings the command line gave: the space is sized to the data only when none of
  // voxel, volume and origin was (size_space_to_view()).
  bool voxel_given = false, trunc_given = false, volume_given = false;
};

struct CoreSetup {
  CoreBuffers buffers;
  TsdfVolume volume;
  int frame_width = 0, frame_height = 0;  //!< the image size given to init() (stage_frame())
  std::vector<float> centre_xyz;  //!< centre_scratch()'s arrays

  //! Carves the arena and checks the sensor against the board's capacity.
  bool init(const BoardCapacities& board, const PinholeIntrinsics& intr, std::string& err);
  //! Binds the volume (dim, voxel, trunc, origin from the settings).
  bool make_volume(const FuseSettings& s, std::string& err);
  //! Copies a frame into the static frame buffers (sizes were checked by init()).
  DepthFrame stage_frame(const std::vector<uint16_t>& depth, const std::vector<Rgb8>* colour);
  //! Binds sensor slot `slot` to a camera (CameraSlot::bind), the error naming the refusal.
  //! \param cam the slot  \param slot index  \param intr the camera  \param kind its filters and noise
  //! \param bilateral bilateral filter on  \param colour_map raycast colour too  \param err why not
  bool bind_camera(CameraSlot& cam, int slot, const PinholeIntrinsics& intr, DepthSensorKind kind, bool bilateral,
                   bool colour_map, std::string& err) const;
  //! The pre-filters' intermediate image: the depth buffer of the board's last sensor slot, which
  //! the single-camera commands do not otherwise use.
  ImageView<uint16_t> spare_image(int width, int height) const;
  //! Scratch for centring a map on a view of `intr`'s size (start-up: allocates once).
  ViewCentreScratch centre_scratch(const PinholeIntrinsics& intr);
  //! One line on the space's voxel pool: bricks in use of the board's, their memory, and the
  //! bricks refused because the pool was full (the map stopped growing there).
  std::string space_usage() const;
  //! Share of pixels a raycast hit, in percent.
  //! \param maps the raycast's maps
  static int hit_percent(const RaycastMaps& maps);
  //! The zero-crossing cloud into the static point buffer, then into `cloud`.
  //! \param cloud output  \param min_weight extract_points' support rule (0: every observed pair)
  //! \param with_support fill cloud.support (each point's evidence, SurfacePoint::support)
  //! \param min_point_weight confidence filter (keep_supported; 0: none)
  Status extract_cloud(io::PointCloud& cloud, uint8_t min_weight = 0, bool with_support = false,
                       int min_point_weight = 0) const;
};

//! The kernels' threads of a host command: a worker pool and its row runners (start-up).
struct PoolRunners {
  WorkerPool pool;
  PoolRowRunner tsdf{pool, 1};
  PoolRowRunner icp{pool};
  //! Starts `threads` workers (the caller included).
  void start(int threads) { pool.start(threads); }
  //! The runners to give the pipeline: ICP rows only over more than one thread.
  KernelRunners runners() const {
    KernelRunners r;
    r.tsdf = tsdf.runner();
    r.icp = pool.size() > 1 ? icp.runner() : nullptr;
    return r;
  }
};

//! Places the volume so that its centre is the median of the points the frame sees.
//! \param depth_path the frame's file, named in the error when no pixel holds a depth in range
bool centre_on_view(const PinholeIntrinsics& intr, const std::vector<uint16_t>& depth, const Pose& T_world_cam,
                    FuseSettings& s, const std::string& depth_path, std::string& err);

//! Writes a cloud as PLY (binary) or PCD (binary) by the file's extension.
bool write_cloud(const std::string& path, const io::PointCloud& cloud, std::string& err);

}  // namespace edgefuse::cli
