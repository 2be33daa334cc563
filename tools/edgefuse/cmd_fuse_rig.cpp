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
#include "edgefuse/hal/platform/threads/parallel_tsdf.hpp"
#include "rig_fusion.hpp"

namespace edgefuse::cli {
namespace {

const char* kUsage =
    "usage: edgefuse fuse RIGSET --sensors A,B,... [--extrinsics true|calibrated|FILE] [--frames N]\n"
    "                     [--voxel M] [--trunc M] [--volume N] [--origin X,Y,Z] [--out FILE.ply|.pcd]\n"
    "                     [--mesh FILE.ply] [--threads N] [--guess tx,ty,tz,rx,ry,rz] [--no-trust]\n"
    "                     [--no-paint] [--no-filter] [--tof-bilateral] [--register-laser] [--laser-patch N]\n"
    "                     [--laser-6dof] [--laser-min-eigen R] [--laser-offset tx,ty,tz,rx,ry,rz]\n"
    "                     [--max-sigma M] [--min-support W | --full-coverage] [--min-weight W] [--jump-sigmas K]\n"
    "                     [--sub-unit-fill N]\n"
    "  Fuses the listed sensors of a rig set into one space. Pinhole sensors are placed by\n"
    "  --extrinsics: 'true' (default) = each sensor's own groundtruth.txt; 'calibrated' = the\n"
    "  reference camera's poses (the first listed with colour, else the first pinhole) times the\n"
    "  mounting found by calibration (as `edgefuse calibrate --frames 20`, reference tracked, from\n"
    "  --guess); FILE = the same with\n"
    "  the mounting read from an extrinsics.txt file. Line scanners use their own poses (the robot's);\n"
    "  --register-laser registers each patch of --laser-patch N profiles (default 300) against the space\n"
    "  before integrating it (cameras are pushed first), as a translation (--laser-6dof: also rotation);\n"
    "  a patch is refused unless every direction's eigenvalue is at least R (default 0.003) of the largest.\n"
    "  --laser-offset puts a known error on every scanner pose (sensor frame; metres, degrees as a\n"
    "  rotation vector), e.g. to measure the registration.\n"
    "  Weights follow each sensor's noise model (--no-trust: equal weights); colour from the\n"
    "  reference camera is painted onto all geometry it saw (--no-paint: only where its own depth was).\n"
    "  ToF frames get the amplitude and jump-edge filters but no bilateral smoothing (--tof-bilateral: they do).\n"
    "  --max-sigma M: pixels whose modelled noise exceeds M metres are not integrated (default 0: all;\n"
    "  half the truncation is the noise the space can hold; needs the noise models, not with --no-trust).\n"
    "  --min-support W: a surface point needs both voxels of its zero crossing to hold at least W weight\n"
    "  units (1/8 of a full-trust sample, weight (sigma_ref/sigma)^2; 0: off). Default with the noise models:\n"
    "  4 (half a sample: one Xtion frame at 0.7 m); 9 (the evidence rule of round 5) only when the set\n"
    "  mixes a camera whose samples weigh less than half a unit (noise above 4 x sigma_ref: the ToF) with\n"
    "  a better one and --sub-unit-fill is 4 or more - then a point needs more support than sub-unit samples\n"
    "  alone can store. --full-coverage: fill 8 and support 4 (round 4's cloud: the ToF-only surface too,\n"
    "  at the ToF's accuracy). --min-weight W: also drop points none of whose 8 voxels holds W.\n"
    "  --sub-unit-fill N: samples worth less than half a weight unit (the ToF next to the Xtion) still fill\n"
    "  a voxel, one unit each, up to N units (1-255). Default: 3 for a set that mixes such a camera with a\n"
    "  better one (below the support rule's 4: a voxel only the ToF saw is never emitted, and the default\n"
    "  support rule is then 4, not 9), else 8 (one sample); 8 with --full-coverage.\n"
    "  --jump-sigmas K: a depth difference of more than K x the frame's median modelled\n"
    "  noise (at least the truncation, at most 1 m) between neighbouring pixels is a discontinuity (default\n"
    "  2.83, up to 10; 0: the truncation, as before round 4).\n";

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
                   "guess", "sigma-ref", "min-weight", "laser-patch", "laser-offset", "laser-min-eigen", "max-sigma",
                   "min-support", "jump-sigmas", "sub-unit-fill"},
                  {"no-trust", "no-paint", "no-filter", "register-laser", "laser-6dof", "tof-bilateral", "full-coverage"},
                  err) ||
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
  float sigma_ref = 0.5f * settings.voxel_m;
  int min_weight = 0;
  if (!args.get_float("sigma-ref", 1e-6f, 1.0f, sigma_ref, err) || !args.get_int("min-weight", 0, 255, min_weight, err))
    return fail(err, 2);
  if (!use_trust) sigma_ref = 0.0f;
  LaserPushOptions laser;
  laser.register_patches = args.has("register-laser");
  laser.verbose = true;
  laser.reg.translation_only = !args.has("laser-6dof");
  if (!args.get_float("laser-min-eigen", 1e-6f, 1.0f, laser.reg.min_eigen_ratio, err)) return fail(err, 2);
  if (!args.get_int("laser-patch", 1, 100000, laser.patch_profiles, err)) return fail(err, 2);
  if (args.has("laser-offset") && !parse_guess(args.get("laser-offset"), laser.offset, err)) {
    const std::string guess = "--guess";  // parse_guess names its own option
    if (err.compare(0, guess.size(), guess) == 0) err = "--laser-offset" + err.substr(guess.size());
    return fail(err, 2);
  }

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
  // ToF frames are not bilateral-smoothed before fusion (--tof-bilateral: they are): with the ToF's
  // noise (6.7 mm median) its range sigma mixes the floor with the tops of the objects on it, which
  // lifted the fused floor by 1.85 mm on bin_rig_a; the TSDF's own average denoises in 3-D without
  // crossing edges (BENCHMARKS "Multi-sensor fusion, round 3").
  for (PinholeSlot& c : cams)
    if (c.tof && !args.has("tof-bilateral")) c.filters.bilateral_enabled = false;
  // Noise gate (off by default): a pixel noisier than M is not integrated. M = trunc/2 is the
  // noise the truncated space can hold (+-2 sigma inside +-trunc; beyond, the clipping biases the
  // average and the noise leaves zero crossings in the band) - but on bin_rig_a at 2 mm voxels it
  // drops every ToF pixel, so by default every sensor's data is fused (where only the ToF sees,
  // its accuracy is what there is) and the gate is the user's choice (BENCHMARKS round 3).
  float max_sigma = 0.0f;
  if (!args.get_float("max-sigma", 0.0f, 1.0f, max_sigma, err)) return fail(err, 2);
  if (use_trust)
    for (PinholeSlot& c : cams) c.sigma_max_m = max_sigma;
  // Round 4 (BENCHMARKS "Multi-sensor fusion, round 4"): the ToF's noise is of the order of the
  // truncation. (1) With the truncation as the depth-jump limit its noise read as depth edges and
  // only 1-4 of 20 frames reached a voxel (at slopes only the samples whose noise cancelled the
  // slope): the jump follows the frame's noise. (2) A zero crossing made by one to three such
  // samples is noise, not surface (70 % of the ToF-only points lay > 2 mm off the true surface,
  // inside the walls and under the floor): extraction needs both voxels to hold half a full sample.
  // Both need the noise models (with --no-trust every sample is a full one).
  // Round 5: the support rule's default follows the set (fusion_rules.hpp, evidence rule), decided
  // after the push from each camera's median noise; --min-support / --full-coverage fix it.
  // Round 5b: in a mixed set sub-unit samples fill a voxel only up to 3 units, so the support
  // rule's default is 4 again (fusion_rules.hpp rule 3).
  int min_support = use_trust ? kMinSupportWeight : 0;
  float jump_sigmas = use_trust ? kJumpSigmas : 0.0f;
  if (!args.get_int("min-support", 0, 255, min_support, err) || !args.get_float("jump-sigmas", 0.0f, 10.0f, jump_sigmas, err))
    return fail(err, 2);
  if (args.has("full-coverage") && args.has("min-support")) return fail("--full-coverage and --min-support exclude each other", 2);
  if (args.has("full-coverage") && !use_trust) return fail("--full-coverage needs the noise models (not with --no-trust)", 2);
  const bool support_by_set = use_trust && !args.has("min-support") && !args.has("full-coverage");
  if (jump_sigmas > 0.0f && !use_trust) return fail("--jump-sigmas needs the noise models (not with --no-trust)", 2);
  for (PinholeSlot& c : cams) c.jump_sigmas = jump_sigmas;
  // Round 5b: how far sub-unit samples fill a voxel (fusion_rules.hpp rule 3): follows the set
  // (decided before the push), 8 with --full-coverage (round 4's cloud), or --sub-unit-fill N.
  int sub_unit_fill = kWeightUnitsPerSample;
  if (!args.get_int("sub-unit-fill", 1, 255, sub_unit_fill, err)) return fail(err, 2);
  if (args.has("sub-unit-fill") && !use_trust) return fail("--sub-unit-fill needs the noise models (not with --no-trust)", 2);
  if (args.has("sub-unit-fill") && args.has("full-coverage"))
    return fail("--full-coverage and --sub-unit-fill exclude each other", 2);
  const bool fill_by_set = use_trust && !args.has("sub-unit-fill") && !args.has("full-coverage");
  for (PinholeSlot& c : cams) c.sub_unit_fill_units = sub_unit_fill;

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

  if (fill_by_set && !plan_sub_unit_fill(rs, filter, sigma_ref, filter_scratch, sub_unit_fill, err)) return fail(err);
  if (use_trust) std::printf("sub-unit fill: samples below half a unit fill a voxel up to %d weight units (%s)\n",
                             sub_unit_fill, fill_by_set ? (sub_unit_fill == kSubUnitFillUnits ? "default, mixed set" : "default")
                                                        : (args.has("full-coverage") ? "--full-coverage" : "--sub-unit-fill"));
  WorkerPool pool;
  pool.start(settings.threads);
  const auto t_start = std::chrono::steady_clock::now();
  if (!push_rig_frames(rs, core, pool, mount, mounted, std::size_t(frames_max), filter, true, sigma_ref,
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
  pool.stop();
  const double fuse_ms = ms_since(t_start);

  if (support_by_set) {
    const std::vector<float> sigma = median_sigmas(cams);
    min_support = default_support_weight(sigma.data(), int(sigma.size()), sigma_ref, sub_unit_fill);
  }
  if (use_trust)
    std::printf("support rule: both voxels of a crossing hold >= %d weight units (%s)\n", min_support,
                support_by_set ? (min_support == kEvidenceSupportWeight ? "default, evidence rule: mixed sub-unit camera"
                                                                         : "default")
                               : (args.has("full-coverage") ? "--full-coverage" : "--min-support"));
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
