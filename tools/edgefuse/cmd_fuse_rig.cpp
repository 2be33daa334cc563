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

#include "failure.hpp"
#include "args.hpp"
#include "commands.hpp"
#include "core_setup.hpp"
#include "fuse_options.hpp"
#include "edgefuse/io/mesh_collector.hpp"
#include "edgefuse/tsdf/colour_pass.hpp"
#include "edgefuse/tsdf/extract.hpp"
#include "rig_calibration.hpp"
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



// What the command line asks for.
struct FuseRigOptions {
  Args args;
  std::string folder;
  FuseSettings settings;
  int frames_max = 0;
  Pose guess;
  bool paint = true;
  MapperParams mapping;  // known poses; filters, noise weights and the fusion rules from the options
  int min_weight = 0;
  LaserPushOptions laser;
};

// The mapping the options ask for: every camera's pre-filters (--no-filter: none) and noise weights
// (--no-trust: equal weights) with the fusion rules (fusion_rules.hpp, shared with edgefused), all
// of which need the noise models:
// - the depth-jump limit follows the frame's noise: with the truncation as the limit, the ToF's
//   noise (of the order of the truncation) reads as depth edges, and only the samples whose noise
//   cancels the slope reach a voxel;
// - a zero crossing needs both voxels to hold half a full sample (support rule): one to three
//   ToF samples make crossings that are noise, inside the walls and under the floor;
// - in a set mixing a sub-unit camera with a better one, the sub-unit samples fill a voxel only
//   up to 3 units (decided before the push from each camera's first frame), so surface only the
//   ToF saw never passes the support rule; the support rule then follows the set (after the
//   push, from each camera's median noise).
// Noise gate (--max-sigma, off by default): a pixel noisier than M is not integrated. M = trunc/2
// is the noise the truncated space can hold (+-2 sigma inside +-trunc; beyond, the clipping biases
// the average and the noise leaves zero crossings in the band) - but on bin_rig_a at 2 mm voxels it
// drops every ToF pixel, so by default every sensor's data is fused (where only the ToF sees, its
// accuracy is what there is) and the gate is the user's choice.
bool mapping_options(const Args& args, MapperParams& mp, std::string& err) {
  mp.poses = PoseMode::kKnown;
  mp.prefilter = !args.has("no-filter");
  mp.noise_weights = !args.has("no-trust");
  if (!args.get_float("max-sigma", 0.0f, 1.0f, mp.rules.noise_gate_m, err)) return false;
  return true;
}

bool parse_options(int argc, char** argv, FuseRigOptions& o, Failure& f) {
  Args& args = o.args;
  std::string err;
  if (!args.parse(argc, argv,
                  {"sensors", "extrinsics", "frames", "voxel", "trunc", "volume", "origin", "out", "mesh", "threads",
                   "guess", "min-weight", "max-sigma"},
                  {"no-trust", "no-paint", "no-filter", "register-laser"}, err) ||
      args.positional().size() != 1) {
    f.usage = true;
    return fail(f, err.empty() ? "expected one RIGSET" : err, 2);
  }
  if (!board_fuse_settings(o.settings, err)) return fail(f, err);
  if (!apply_fuse_options(args, o.settings, o.frames_max, err) ||
      (args.has("guess") && !parse_guess(args.get("guess"), o.guess, err)))
    return fail(f, err, 2);
  o.paint = !args.has("no-paint");
  if (!mapping_options(args, o.mapping, err) || !args.get_int("min-weight", 0, 255, o.min_weight, err))
    return fail(f, err, 2);
  o.laser.register_patches = args.has("register-laser");
  o.laser.verbose = true;
  o.folder = args.positional()[0];
  return true;
}

// The core and the sensors bound to it.
struct RigCore {
  io::RigSet set;
  RigSensors rs;
  CoreSetup core;
  ImageView<uint16_t> filter_scratch;
  RigMounting mounting;
  Mapper mapper;
};

bool open_sensors(const FuseRigOptions& o, RigCore& rc, Failure& f) {
  std::string err;
  if (!io::open_rig_set(o.folder, rc.set, err)) return fail(f, err);
  bool usage = false;
  if (!open_rig_sensors(o.folder, rc.set, split_names(o.args.get("sensors")), build_board(), rc.rs, err, usage))
    return fail(f, err, usage ? 2 : 1);
  return true;
}

// The core's buffers and every camera bound to its slot. ToF frames are not bilateral-smoothed
// before fusion: with the ToF's noise (6.7 mm median) its range sigma mixes the floor with the tops
// of the objects on it, which lifts the fused floor by 1.85 mm on bin_rig_a; the TSDF's own average
// denoises in 3-D without crossing edges.
bool bind_sensors(RigCore& rc, Failure& f) {
  const BoardCapacities& board = build_board();
  std::string err;
  PinholeIntrinsics init_intr;
  init_intr.width = init_intr.height = 8;
  init_intr.fx = init_intr.fy = 8;
  const int ref = rc.rs.ref;
  if (!rc.core.init(board, ref >= 0 ? rc.rs.cams[std::size_t(ref)].seq.intr : init_intr, err)) return fail(f, err);
  if (!bind_rig_sensors(rc.rs, rc.core, false, rc.filter_scratch, err)) return fail(f, err);
  return true;
}

// Volume placement.
bool place_volume(FuseRigOptions& o, RigCore& rc, Failure& f) {
  std::string err;
  FuseSettings& settings = o.settings;
  if (!settings.origin_given && !place_rig_volume(rc.rs, settings, err)) return fail(f, err);
  if (!rc.core.make_volume(settings, err)) return fail(f, err);
  const Vec3f& org = rc.core.volume.origin_m();
  std::printf("edgefuse fuse: %s, sensors %s, volume %d^3 x %.4f m at %.4f,%.4f,%.4f, trunc %.4f m, trust %s, %s "
              "kernels\n",
              o.folder.c_str(), o.args.get("sensors").c_str(), settings.dim, settings.voxel_m, org.x(), org.y(),
              org.z(), settings.trunc_m, o.mapping.noise_weights ? "noise models" : "off",
              kFixedPointBuild ? "fixed-point" : "float");
  return true;
}

// --extrinsics calibrated: camera i's mounting found by calibration (as `edgefuse calibrate --frames 20`,
// reference tracked, from --guess); the space is cleared after.
bool calibrate_mounting(const FuseRigOptions& o, RigCore& rc, std::size_t i, Failure& f) {
  std::vector<RigCamera>& cams = rc.rs.cams;
  RigCamera& r = cams[std::size_t(rc.rs.ref)];
  std::string err;
  PairCalibrationSetup setup;
  setup.volume = &rc.core.volume;
  setup.filter_scratch = rc.filter_scratch;
  setup.centre = rc.core.centre_scratch(r.seq.intr);
  setup.frames = std::min(o.frames_max, 20);
  setup.guess = o.guess;
  PairCalibrationRun run;
  std::printf("calibrating T_%s_%s ...\n", r.seq.sensor_name.c_str(), cams[i].seq.sensor_name.c_str());
  if (!run_pair_calibration(r, cams[i], setup, run, err)) return fail(f, err);
  rc.core.volume.clear();
  if (run.accepted == 0)
    return fail(f, "calibration of " + cams[i].seq.sensor_name + " refused: " + run.first_reason, 3);
  rc.mounting.T_ref_cam[i] = run.T_a_b;
  std::printf("T_%s_%s = %s (%d frames)\n", r.seq.sensor_name.c_str(), cams[i].seq.sensor_name.c_str(),
              pose_line(run.T_a_b).c_str(), run.accepted);
  return true;
}

// --extrinsics FILE: camera i's mounting read from an extrinsics.txt file (the last matching line).
bool read_mounting(const std::string& extr, const std::vector<io::SensorExtrinsic>& file, RigCore& rc, std::size_t i,
                   Failure& f) {
  const RigCamera& r = rc.rs.cams[std::size_t(rc.rs.ref)];
  const RigCamera& c = rc.rs.cams[i];
  bool found = false;
  for (const io::SensorExtrinsic& e : file)
    if (e.sensor_a == r.seq.sensor_name && e.sensor_b == c.seq.sensor_name) {
      rc.mounting.T_ref_cam[i] = e.T_a_b;
      found = true;
    }
  if (!found) return fail(f, extr + " has no line '" + r.seq.sensor_name + " " + c.seq.sensor_name + " ...'");
  return true;
}

// Mountings of the non-reference cameras (--extrinsics true: none, each camera at its own poses).
bool mount_cameras(const FuseRigOptions& o, RigCore& rc, Failure& f) {
  const std::size_t cams = rc.rs.cams.size();
  const std::string extr = o.args.get("extrinsics", "true");
  rc.mounting.T_ref_cam.assign(cams, Pose());
  rc.mounting.mounted.assign(cams, 0);
  if (extr == "true") return true;
  if (rc.rs.ref < 0) return fail(f, "--extrinsics " + extr + " needs a pinhole reference camera", 2);
  std::string err;
  std::vector<io::SensorExtrinsic> file;
  if (extr != "calibrated" && !io::read_extrinsics_txt(extr, file, err)) return fail(f, err);
  for (std::size_t i = 0; i < cams; ++i) {
    if (int(i) == rc.rs.ref) continue;
    if (!(extr == "calibrated" ? calibrate_mounting(o, rc, i, f) : read_mounting(extr, file, rc, i, f))) return false;
    rc.mounting.mounted[i] = 1;
  }
  return true;
}

// The reference camera's colour painted onto all the geometry it saw.
bool paint_reference_colour(const FuseRigOptions& o, RigCore& rc, Failure& f) {
  RigCamera& rig_cam = rc.rs.cams[std::size_t(rc.rs.ref)];
  CameraSlot& cam = rig_cam.cam;
  const io::DepthSequence& seq = rig_cam.seq;
  std::string err;
  const std::size_t n = std::min<std::size_t>(seq.frames.size(), std::size_t(o.frames_max));
  for (std::size_t i = 0; i < n; ++i) {
    const io::FrameRef& fr = seq.frames[i];
    if (fr.colour_path.empty() || !fr.has_pose) continue;
    if (!io::load_colour(fr, seq.intr, rig_cam.load_colour, err)) return fail(f, err);
    const ImageView<const Rgb8> colour(rig_cam.load_colour.data(), seq.intr.width, seq.intr.height);
    const Status s = paint_colour<real_t>(rc.core.volume, seq.intr, cam.ray_norms, colour, fr.T_world_cam, cam.maps,
                                          cam.scratch, cam.filtered);
    if (s != Status::kOk) return fail(f, fr.colour_path + ": paint pass: " + to_string(s));
  }
  std::printf("%s: colour painted onto the fused surface from %zu frames\n", seq.sensor_name.c_str(), n);
  return true;
}

// Every sensor's frames into the space through the pipeline's Mapper, then the colour; fuse_ms:
// the time both took.
bool fuse_frames(const FuseRigOptions& o, RigCore& rc, double& fuse_ms, Failure& f) {
  std::string err;
  PoolRunners threads;
  threads.start(o.settings.threads);
  Mapper& mapper = rc.mapper;
  if (!start_rig_mapper(rc.rs, rc.core, threads.runners(), rc.filter_scratch, o.mapping, mapper, err)) return fail(f, err);
  if (o.mapping.noise_weights) {
    int fill = 0;
    if (!plan_sub_unit_fill(rc.rs, mapper, fill, err)) return fail(f, err);
    std::printf("sub-unit fill: samples below half a unit fill a voxel up to %d weight units (%s)\n", fill,
                fill == kSubUnitFillUnits ? "mixed set" : "one sample");
  }
  const auto t_start = std::chrono::steady_clock::now();
  if (!push_rig_frames(rc.rs, mapper, rc.core, rc.mounting, std::size_t(o.frames_max), true, err, true, o.laser))
    return fail(f, err);
  const int ref = rc.rs.ref;
  if (o.paint && ref >= 0 && rc.rs.cams[std::size_t(ref)].seq.colour_registered && rc.core.volume.has_colour() &&
      !paint_reference_colour(o, rc, f))
    return false;
  threads.pool.stop();
  fuse_ms = ms_since(t_start);
  return true;
}

// The cloud (and the mesh), under the set's support rule; the summary line.
bool write_outputs(const FuseRigOptions& o, RigCore& rc, double fuse_ms, Failure& f) {
  CoreSetup& core = rc.core;
  std::string err;
  const int min_support = rc.mapper.support_weight();
  if (o.mapping.noise_weights) {
    std::printf("support rule: both voxels of a crossing hold >= %d weight units%s\n", min_support,
                min_support == kEvidenceSupportWeight ? " (evidence rule: mixed sub-unit camera)" : "");
  }
  io::PointCloud cloud;
  // Each point carries its evidence (the weaker voxel's weight) as the property / field "support".
  // --min-weight: a point is kept only where some of the 8 voxels around it holds that much
  // weight (keep_supported), i.e. the surface there is supported by that much data.
  const Status xs = core.extract_cloud(cloud, uint8_t(min_support), true, o.min_weight);
  std::size_t coloured = 0;
  for (const Rgba8& c : cloud.colours) coloured += c.a != 0;
  const std::string out = o.args.get("out", "fused.ply");
  if (!write_cloud(out, cloud, err)) return fail(f, err);
  std::printf("cloud: %zu points (%zu coloured, %zu uncoloured)%s -> %s\n", cloud.size(), coloured,
              cloud.size() - coloured, xs == Status::kOutputTruncated ? " (truncated at the board's capacity)" : "",
              out.c_str());
  if (o.args.has("mesh")) {
    io::PlyMeshCollector mesh;
    const Status ms = extract_mesh(core.volume, core.buffers.mesh_scratch, mesh, uint8_t(min_support));
    if (ms != Status::kOk || !mesh.write(o.args.get("mesh"), err))
      return fail(f, "mesh: " + (ms != Status::kOk ? std::string(to_string(ms)) : err));
    std::printf("mesh: %zu vertices -> %s\n", mesh.mesh().vertices.size(), o.args.get("mesh").c_str());
  }
  std::printf("%s\n", core.space_usage().c_str());
  std::printf("sensors=%s points=%zu coloured=%zu voxels=%zu fuse_ms=%.1f\n", o.args.get("sensors").c_str(),
              cloud.size(), coloured, core.volume.observed_voxels(), fuse_ms);
  return true;
}

}  // namespace

int cmd_fuse_rig(int argc, char** argv) {
  if (help_asked(argc, argv, kUsage)) return 0;
  FuseRigOptions o;
  Failure f;
  RigCore rc;
  double fuse_ms = 0;
  if (!parse_options(argc, argv, o, f) || !open_sensors(o, rc, f) || !bind_sensors(rc, f) ||
      !place_volume(o, rc, f) || !mount_cameras(o, rc, f) ||
      !fuse_frames(o, rc, fuse_ms, f) || !write_outputs(o, rc, fuse_ms, f))
    return report("edgefuse fuse", f, kUsage);
  return 0;
}

}  // namespace edgefuse::cli
