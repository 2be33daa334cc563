// The localisation job on a map: surface extraction -> scene (nearest-neighbour grid, normals,
// viewpoint) -> bin (detected, or given by configuration) -> object poses with every loaded model,
// or model-free segments without models, in picking order (Localizer::results()). edgefused runs
// run_localization_job() on its localisation thread; `edgefuse localize` runs the stages one by one,
// printing its diagnostics between them. No heap; the points go to the board's point buffer.
#pragma once

#include <cstddef>
#include <cstdint>

#include "edgefuse/localize/localizer.hpp"
#include "edgefuse/tsdf/extract.hpp"
#include "edgefuse/tsdf/volume.hpp"

namespace edgefuse {

//! The scene grid's cell in voxels: measured fastest of 1.5 / 2.5 / 3.5 / 5 voxels on bin_rig_a,
//! with the same poses.
inline constexpr float kSceneGridVoxels = 3.5f;

//! What the job does.
struct LocalizationRequest {
  LocalizeParams params;              //!< matching, verification, bin and segmentation settings
  int max_results = 0;                //!< at most this many results (<= the board's objects_max)
  bool segments = false;              //!< model-free segments (else poses with the loaded models)
  const BinGeometry* bin = nullptr;   //!< the bin from configuration (null: detect it)
  uint8_t support_weight = 0;         //!< extraction's support rule (Mapper::support_weight())
  uint8_t min_point_weight = 0;       //!< confidence filter: drop points no voxel around which holds this (0: none)
  Vec3f viewpoint_m = Vec3f::Zero();  //!< where the map was seen from (Mapper::mean_viewpoint())
};

//! What it found.
struct LocalizationReport {
  Status status = Status::kOk;
  const char* failed = "";         //!< the stage that refused: "extraction", "scene", "localisation"
  std::size_t surface_points = 0;  //!< extracted (and loaded into the scene)
  std::size_t weak_points = 0;     //!< extracted but dropped by the confidence filter
  bool truncated = false;          //!< the surface exceeded the board's point capacity
  std::size_t scene_points = 0;    //!< scene points before bin removal
  std::size_t count = 0;           //!< results in Localizer::results()
};

//! Stage 1: the map's surface into `points` and the localiser's scene.
//! \param volume the map  \param points the board's point buffer  \param capacity its size
//! \param request viewpoint and support rule  \param loc the localiser  \param report filled
Status load_map_scene(const TsdfVolume& volume, SurfacePoint* points, std::size_t capacity,
                      const LocalizationRequest& request, Localizer& loc, LocalizationReport& report);
//! Stage 2: removes the bin (from configuration or detected). \param request bin and params
//! \param loc the localiser with its scene  \param report scene_points set
Status remove_bin(const LocalizationRequest& request, Localizer& loc, LocalizationReport& report);
//! Stage 3: poses or segments into loc.results(). \param request what to find \param loc the localiser
//! \param report count set
Status find_objects(const LocalizationRequest& request, Localizer& loc, LocalizationReport& report);
//! All three stages.
Status run_localization_job(const TsdfVolume& volume, SurfacePoint* points, std::size_t capacity,
                        const LocalizationRequest& request, Localizer& loc, LocalizationReport& report);

}  // namespace edgefuse
