// Localisation inputs and outputs on the host and at start-up on the board: model files into the localiser, clouds into scene points,
// the pose list and the segment labels out. Host code: may allocate.
#pragma once

#include <string>
#include <vector>

#include "edgefuse/io/cloud.hpp"
#include "edgefuse/io/rig.hpp"
#include "edgefuse/localize/localizer.hpp"

namespace edgefuse::io {

//! Reads a model (PLY mesh in metres; or a PLY/PCD cloud, normals estimated when absent) into `loc`.
//! \return false with `err` saying what is wrong with the file
bool load_model(Localizer& loc, const std::string& path, const LocalizeParams& params, int& index, std::string& err);

//! Scene points of a camera-frame cloud: its normals, or organised-neighbour / PCA normals.
//! \param beyond set to the number of finite points that are not localizable() (skipped)
//! \return false with `err` when fewer than 100 points with normals remain
bool cloud_scene_points(const io::PointCloud& cloud, std::vector<ScenePoint>& out, std::size_t& beyond, std::string& err);

//! Normals by PCA over neighbours within radius_m, turned towards `viewpoint` (host helper).
void estimate_normals_pca(const std::vector<Vec3f>& points, float radius_m, const Vec3f& viewpoint,
                          std::vector<Vec3f>& normals);

//! The bin from a configuration file instead of detection (TOML):
//!   [bin]
//!   pose = [tx, ty, tz, qx, qy, qz, qw]  # T_world_bin: z up, origin at the centre of the inner floor
//!   inner_size_m = [x, y]                # inner floor size along the bin's x and y axes
//! \param path the file  \param bin result
//! \return false with `err` naming the file and the bad key (missing, not a number, a quaternion
//!         that is not unit within 1e-3, a size outside (0, 10] m)
bool read_bin_toml(const std::string& path, BinGeometry& bin, std::string& err);

//! The localisation part of a runtime configuration (edgefused.toml layout): `[localize] models` =
//! a PLY file or a folder of them (every *.ply, sorted, as edgefused reads it) or a list of files, and, optionally,
//! `[localize] bin` = a bin file for read_bin_toml (relative paths: relative to the configuration's
//! folder). Missing keys leave the outputs empty.
//! \param path the configuration  \param models model files found  \param bin_file the bin file or ""
//! \return false with `err` naming the file and key (not a string, folder without models, parse error)
bool read_localize_config(const std::string& path, std::vector<std::string>& models, std::string& bin_file,
                          std::string& err);

//! The model files of `spec`: a PLY file, or every *.ply of a folder (sorted: a stable id order).
//! \param spec a file or folder  \param out files appended
//! \return false with `err` naming `spec` (missing, unreadable folder, folder without models)
bool model_files(const std::string& spec, std::vector<std::string>& out, std::string& err);

//! The models a program localises with: `spec` (model_files) when given, else the models the
//! rig set `replay_dir` lists (rig.toml [[object]]), else none (model-free segments).
//! \param spec the configured models ("": none)  \param replay_dir a replayed recording ("": none)
//! \param out model files, each once  \param err names the file or option that was wrong
bool model_files_for(const std::string& spec, const std::string& replay_dir, std::vector<std::string>& out,
                     std::string& err);

//! The extrinsics.txt of a rig set `folder` when it has one (else `out` stays empty).
//! \param folder the set  \param out its sensor pairs  \param err names the file and line
bool read_rig_extrinsics(const std::string& folder, std::vector<SensorExtrinsic>& out, std::string& err);

//! `id tx ty tz qx qy qz qw score model` per result.
bool write_pose_list(const std::string& path, const Localizer& loc, std::size_t count, std::string& err);

//! Labels per input point (organised cloud: same width x height) or per fused surface point.
bool write_segment_labels(const std::string& path, const Localizer& loc, const io::PointCloud& input,
                          std::size_t surface_count, const SurfacePoint* surface, std::string& err);


}  // namespace edgefuse::io
