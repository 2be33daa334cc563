// edgefuse fuse RIGSET --sensors a,b,c: every listed sensor of a rig set pushes into one space
// (pinhole cameras: pre-filters + per-pixel trust from their noise model; line scanners: profile
// integration in the scan plane), then the RGB-D camera's colour is painted onto the fused surface
// (colour_pass.hpp) so that geometry only the other sensors measured is coloured where the colour
// camera saw it; points never seen in colour stay uncoloured (alpha 0).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "args.hpp"
#include "commands.hpp"
#include "core_setup.hpp"
#include "fuse_options.hpp"
#include "edgefuse/io/mesh_collector.hpp"
#include "edgefuse/tsdf/colour_pass.hpp"
#include "edgefuse/tsdf/extract.hpp"
#include "edgefuse/tsdf/integrate_profile.hpp"
#include "rig_fusion.hpp"

namespace edgefuse::cli {
namespace {

const char* kUsage =
    "usage: edgefuse fuse RIGSET --sensors A,B,... [--extrinsics true|calibrated|FILE] [--guess tx,ty,tz,rx,ry,rz]\n"
    "                     [--frames N] [--voxel M] [--trunc M] [--volume N] [--origin X,Y,Z] [--threads N]\n"
    "                     [--out FILE.ply|.pcd] [--mesh FILE.ply] [--register-laser] [--max-sigma M]\n"
    "                     [--min-weight W] [--no-trust] [--no-paint] [--no-filter]\n"
    "  Fuses the listed sensors of a rig set into one space. Pinhole sensors are placed by\n"
    "  --extrinsics: 'true' (default) = each sensor's own groundtruth.txt; 'calibrated' = the\n"
    "  reference camera's poses (the first listed with colour, else the first pinhole) times the\n"
    "  mounting found by calibration (as `edgefuse calibrate --frames 20`, reference tracked, from\n"
    "  --guess); FILE = the same with the mounting read from an extrinsics.txt file. Line scanners\n"
    "  use their own poses (the robot's); --register-laser registers the scanner's profiles against\n"
    "  the space before integrating them (cameras are pushed first), in patches of 300 profiles, as a\n"
    "  translation (the robot's orientation is trusted).\n"
    "  Weights follow each sensor's noise model (--no-trust: equal weights); colour from the\n"
    "  reference camera is painted onto all geometry it saw (--no-paint: only where its own depth was).\n"
    "  Depth frames get their sensor kind's pre-filters (--no-filter: none); ToF frames are not\n"
    "  bilateral-smoothed. With the noise models, neighbouring pixels further apart than 2.83 x the\n"
    "  frame's median modelled noise (at least the truncation) are a depth discontinuity, and a surface\n"
    "  point needs both voxels of its zero crossing to hold 4 weight units (half a sample at half a\n"
    "  voxel's noise); in a set that mixes a camera whose samples weigh less than half a unit (the ToF)\n"
    "  with a better one, those samples fill a voxel only up to 3 units, so surface only they saw is\n"
    "  not emitted. The lines 'sub-unit fill' and 'support rule' say what the set took.\n"
    "  --max-sigma M: pixels whose modelled noise exceeds M metres are not integrated (default 0: all;\n"
    "  half the truncation is the noise the space can hold; needs the noise models, not with --no-trust).\n"
    "  --min-weight W: also drop points none of whose 8 voxels holds W weight units.\n";

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

int fail(const std::string& msg, int code = 1) {
  std::fprintf(stderr, "edgefuse fuse: %s\n", msg.c_str());
  return code;
}

}  // namespace

int cmd_fuse_rig(int argc, char** argv) {
  Args args;
  std::string err;
  if (!args.parse(argc, argv,
                  {"sensors", "extrinsics", "frames", "voxel", "trunc", "volume", "origin", "out", "mesh", "threads",
                   "guess", "min-weight", "max-sigma"},
                  {"no-trust", "no-paint", "no-filter", "register-laser"}, err) ||
      args.positional().size() != 1) {
    std::fprintf(stderr, "edgefuse fuse: %s\n%s", err.empty() ? "expected one RIGSET" : err.c_str(), kUsage);
    return 2;
  }
  const BoardCapacities& board = build_board();
  FuseSettings settings;
  if (!board_fuse_settings(settings, err)) return fail(err);
  int frames_max = 0;
  Pose guess;
  if (!apply_fuse_options(args, settings, frames_max, err) ||
      (args.has("guess") && !parse_guess(args.get("guess"), guess, err)))
    return fail(err, 2);
  const bool use_trust = !args.has("no-trust"), paint = !args.has("no-paint"), filter = !args.has("no-filter");
  // Trust reference: a sample with half a voxel of noise weighs one full sample.
  const float sigma_ref = use_trust ? 0.5f * settings.voxel_m : 0.0f;
  int min_weight = 0;
  if (!args.get_int("min-weight", 0, 255, min_weight, err)) return fail(err, 2);
  LaserPushOptions laser;
  laser.register_patches = args.has("register-laser");
  laser.verbose = true;

  const std::string folder = args.positional()[0];
  io::RigSet set;
  if (!io::open_rig_set(folder, set, err)) return fail(err);
  RigSensors rs;
  bool usage = false;
  if (!open_rig_sensors(folder, set, split_names(args.get("sensors")), board, rs, err, usage))
    return fail(err, usage ? 2 : 1);
  std::vector<PinholeSlot>& cams = rs.cams;
  const int ref = rs.ref;

  CoreSetup core;
  PinholeIntrinsics init_intr;
  init_intr.width = init_intr.height = 8;
  init_intr.fx = init_intr.fy = 8;
  if (!core.init(board, ref >= 0 ? cams[std::size_t(ref)].seq.intr : init_intr, err)) return fail(err);
  ImageView<uint16_t> filter_scratch;
  if (!bind_rig_sensors(rs, core, board, filter_scratch, err)) return fail(err);
  // ToF frames are not bilateral-smoothed before fusion: with the ToF's noise (6.7 mm median) its
  // range sigma mixes the floor with the tops of the objects on it, which lifts the fused floor by
  // 1.85 mm on bin_rig_a; the TSDF's own average denoises in 3-D without crossing edges.
  for (PinholeSlot& c : cams)
    if (c.tof) c.filters.bilateral_enabled = false;
  // Noise gate (off by default): a pixel noisier than M is not integrated. M = trunc/2 is the
  // noise the truncated space can hold (+-2 sigma inside +-trunc; beyond, the clipping biases the
  // average and the noise leaves zero crossings in the band) - but on bin_rig_a at 2 mm voxels it
  // drops every ToF pixel, so by default every sensor's data is fused (where only the ToF sees,
  // its accuracy is what there is) and the gate is the user's choice.
  float max_sigma = 0.0f;
  if (!args.get_float("max-sigma", 0.0f, 1.0f, max_sigma, err)) return fail(err, 2);
  if (use_trust)
    for (PinholeSlot& c : cams) c.sigma_max_m = max_sigma;
  // The noise rules (fusion_rules.hpp, shared with edgefused), all of which need the noise models
  // (with --no-trust every sample is a full one):
  // - the depth-jump limit follows the frame's noise: with the truncation as the limit, the ToF's
  //   noise (of the order of the truncation) reads as depth edges, and only the samples whose noise
  //   cancels the slope reach a voxel;
  // - a zero crossing needs both voxels to hold half a full sample (support rule): one to three
  //   ToF samples make crossings that are noise, inside the walls and under the floor;
  // - in a set mixing a sub-unit camera with a better one, the sub-unit samples fill a voxel only
  //   up to 3 units (decided before the push from each camera's first frame), so surface only the
  //   ToF saw never passes the support rule; the support rule then follows the set (after the
  //   push, from each camera's median noise).
  for (PinholeSlot& c : cams) c.jump_sigmas = use_trust ? kJumpSigmas : 0.0f;
  int sub_unit_fill = kWeightUnitsPerSample;

  // Volume placement.
  if (!settings.origin_given && !place_rig_volume(rs, settings, err)) return fail(err);
  if (!core.make_volume(settings, err)) return fail(err);
  const Vec3f& o = core.volume.origin_m();
  std::printf("edgefuse fuse: %s, sensors %s, volume %d^3 x %.4f m at %.4f,%.4f,%.4f, trunc %.4f m, trust %s, %s "
              "kernels\n",
              folder.c_str(), args.get("sensors").c_str(), settings.dim, settings.voxel_m, o.x(), o.y(), o.z(),
              settings.trunc_m, use_trust ? "noise models" : "off", kFixedPointBuild ? "fixed-point" : "float");

  // Mountings of the non-reference cameras.
  const std::string extr = args.get("extrinsics", "true");
  std::vector<Pose> mount(cams.size());
  std::vector<char> mounted(cams.size(), 0);
  if (extr != "true") {
    if (ref < 0) return fail("--extrinsics " + extr + " needs a pinhole reference camera", 2);
    const PinholeSlot& r = cams[std::size_t(ref)];
    std::vector<io::SensorExtrinsic> file;
    if (extr != "calibrated" && !io::read_extrinsics_txt(extr, file, err)) return fail(err);
    for (std::size_t i = 0; i < cams.size(); ++i) {
      if (int(i) == ref) continue;
      if (extr == "calibrated") {
        FramePyramid<real_t> pyramid;
        if (core.buffers.pyramid<real_t>(cams[i].slot, cams[i].seq.intr, pyramid) != Status::kOk)
          return fail("pyramid does not fit");
        PairCalibrationRun run;
        std::printf("calibrating T_%s_%s ...\n", r.seq.sensor_name.c_str(), cams[i].seq.sensor_name.c_str());
        FramePyramid<real_t> pyramid_ref;
        if (core.buffers.pyramid<real_t>(r.slot, r.seq.intr, pyramid_ref) != Status::kOk) return fail("pyramid does not fit");
        TrackingBuffers track{&pyramid_ref, core.buffers.icp_workspace<real_t>(r.slot)};
        if (!run_pair_calibration(cams[std::size_t(ref)], cams[i], core.volume, pyramid,
                                  core.buffers.icp_workspace<real_t>(cams[i].slot), filter_scratch,
                                  std::min(frames_max, 20), guess, PairCalibrationParams(), run, err, false, &track))
          return fail(err);
        core.volume.clear();
        if (run.accepted == 0) return fail("calibration of " + cams[i].seq.sensor_name + " refused: " + run.first_reason, 3);
        mount[i] = run.T_a_b;
        std::printf("T_%s_%s = %s (%d frames)\n", r.seq.sensor_name.c_str(), cams[i].seq.sensor_name.c_str(),
                    pose_line(run.T_a_b).c_str(), run.accepted);
      } else {
        bool found = false;
        for (const io::SensorExtrinsic& e : file)
          if (e.sensor_a == r.seq.sensor_name && e.sensor_b == cams[i].seq.sensor_name) {
            mount[i] = e.T_a_b;
            found = true;
          }
        if (!found) return fail(extr + " has no line '" + r.seq.sensor_name + " " + cams[i].seq.sensor_name + " ...'");
      }
      mounted[i] = 1;
    }
  }

  if (use_trust) {
    if (!plan_sub_unit_fill(rs, filter, sigma_ref, filter_scratch, sub_unit_fill, err)) return fail(err);
    std::printf("sub-unit fill: samples below half a unit fill a voxel up to %d weight units (%s)\n", sub_unit_fill,
                sub_unit_fill == kSubUnitFillUnits ? "mixed set" : "one sample");
  }
  PoolRunners threads;
  threads.start(settings.threads);
  const auto t_start = std::chrono::steady_clock::now();
  if (!push_rig_frames(rs, core, threads.runners().tsdf, mount, mounted, std::size_t(frames_max), filter, true, sigma_ref,
                       filter_scratch, err, true, laser))
    return fail(err);
  if (paint && ref >= 0 && cams[std::size_t(ref)].seq.colour_registered && core.volume.has_colour()) {
    PinholeSlot& cam = cams[std::size_t(ref)];
    const std::size_t n = std::min<std::size_t>(cam.seq.frames.size(), std::size_t(frames_max));
    for (std::size_t i = 0; i < n; ++i) {
      const io::FrameRef& f = cam.seq.frames[i];
      if (f.colour_path.empty() || !f.has_pose) continue;
      if (!io::load_colour(f, cam.seq.intr, cam.load_colour, err)) return fail(err);
      std::copy(cam.load_colour.begin(), cam.load_colour.end(), cam.colour.data);
      const Status s = paint_colour<real_t>(core.volume, cam.seq.intr, cam.ray_norms, cam.colour, f.T_world_cam,
                                            cam.maps, cam.scratch, cam.depth);
      if (s != Status::kOk) return fail(f.colour_path + ": paint pass: " + to_string(s));
    }
    std::printf("%s: colour painted onto the fused surface from %zu frames\n", cam.seq.sensor_name.c_str(), n);
  }
  threads.pool.stop();
  const double fuse_ms = ms_since(t_start);

  int min_support = 0;
  if (use_trust) {
    const std::vector<float> sigma = median_sigmas(cams);
    min_support = default_support_weight(sigma.data(), int(sigma.size()), sigma_ref, sub_unit_fill);
    std::printf("support rule: both voxels of a crossing hold >= %d weight units%s\n", min_support,
                min_support == kEvidenceSupportWeight ? " (evidence rule: mixed sub-unit camera)" : "");
  }
  io::PointCloud cloud;
  // Each point carries its evidence (the weaker voxel's weight) as the property / field "support".
  const Status xs = core.extract_cloud(cloud, uint8_t(min_support), true);
  if (min_weight > 0) {
    // Confidence filter: keep a point only where some of the 8 voxels around it holds at least
    // min_weight (weight units: 1/8 sample x trust), i.e. the surface there is supported by that much data.
    std::size_t kept = 0;
    for (std::size_t i = 0; i < cloud.points.size(); ++i) {
      if (support_weight(core.volume, cloud.points[i]) < min_weight) continue;
      cloud.points[kept] = cloud.points[i];
      cloud.normals[kept] = cloud.normals[i];
      if (!cloud.colours.empty()) cloud.colours[kept] = cloud.colours[i];
      cloud.support[kept] = cloud.support[i];
      ++kept;
    }
    cloud.points.resize(kept);
    cloud.normals.resize(kept);
    if (!cloud.colours.empty()) cloud.colours.resize(kept);
    cloud.support.resize(kept);
    cloud.width = int(kept);
  }
  std::size_t coloured = 0;
  for (const Rgba8& c : cloud.colours) coloured += c.a != 0;
  const std::string out = args.get("out", "fused.ply");
  if (!write_cloud(out, cloud, err)) return fail(err);
  std::printf("cloud: %zu points (%zu coloured, %zu uncoloured)%s -> %s\n", cloud.size(), coloured,
              cloud.size() - coloured, xs == Status::kOutputTruncated ? " (truncated at the board's capacity)" : "",
              out.c_str());
  if (args.has("mesh")) {
    io::PlyMeshCollector mesh;
    const Status ms = extract_mesh(core.volume, core.buffers.mesh_scratch, mesh, uint8_t(min_support));
    if (ms != Status::kOk || !mesh.write(args.get("mesh"), err))
      return fail("mesh: " + (ms != Status::kOk ? std::string(to_string(ms)) : err));
    std::printf("mesh: %zu vertices -> %s\n", mesh.mesh().vertices.size(), args.get("mesh").c_str());
  }
  std::printf("sensors=%s points=%zu coloured=%zu voxels=%zu fuse_ms=%.1f\n", args.get("sensors").c_str(), cloud.size(),
              coloured, core.volume.observed_voxels(), fuse_ms);
  return 0;
}

}  // namespace edgefuse::cli
