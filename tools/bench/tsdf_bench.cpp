// Benchmark of the TSDF kernels alone: fuses a sequence at its ground-truth
// poses with the board defaults, then raycasts every pose of the sequence again on the final
// volume. Prints thread CPU time (CLOCK_THREAD_CPUTIME_ID: the figure that survives a loaded
// machine) per integration and per raycast, in the build's scalar (float or Q16.16).
// --dump / --compare write and compare the raycast depth and normal maps of two builds, so a
// speed change can be shown not to change the result. Host only; allocates freely.
//
// usage: edgefuse_tsdf_bench DATASET [--sensor NAME] [--frames N] [--voxel M] [--reps R] [--no-colour-map] [--truth]
//                            [--no-raycast] [--dump FILE] [--compare FILE] [--cast-level L]
//                            [--cast-threads N]
#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "failure.hpp"
#include "args.hpp"
#include "core_setup.hpp"
#include "edgefuse/io/dataset.hpp"
#include "edgefuse/memory/arena.hpp"
#include "edgefuse/tracking/pyramid.hpp"
#include "fuse_options.hpp"
#include "edgefuse/pipeline/kernels.hpp"

using namespace edgefuse;
using namespace edgefuse::cli;

namespace {

double clock_ms(clockid_t clock) {
  timespec ts;
  clock_gettime(clock, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}
double thread_cpu_ms() { return clock_ms(CLOCK_THREAD_CPUTIME_ID); }

// Depth of every final raycast, then its normals (x, y, z per pixel), one pose after the other.
struct MapDump {
  std::vector<float> values;
  void add(const RaycastMaps& maps, std::size_t pixels) {
    values.insert(values.end(), maps.depth_m.data, maps.depth_m.data + pixels);
    for (std::size_t k = 0; k < pixels; ++k) {
      const Vec3f n = maps.normal.empty() ? Vec3f::Zero() : maps.normal.data[k];
      values.push_back(n.x());
      values.push_back(n.y());
      values.push_back(n.z());
    }
  }
};

// Prints how the maps of this run differ from those of an earlier run (hit/miss, depth, normal).
bool compare_dumps(const MapDump& mine, const std::string& path, std::size_t pixels, float voxel_m) {
  FILE* fp = std::fopen(path.c_str(), "rb");
  if (fp == nullptr) {
    std::fprintf(stderr, "edgefuse_tsdf_bench: cannot open --compare file %s\n", path.c_str());
    return false;
  }
  std::vector<float> other(mine.values.size());
  const std::size_t got = std::fread(other.data(), sizeof(float), other.size(), fp);
  const bool longer = std::fgetc(fp) != EOF;
  std::fclose(fp);
  if (got != other.size() || longer) {
    std::fprintf(stderr, "edgefuse_tsdf_bench: %s holds maps of another run (size differs)\n", path.c_str());
    return false;
  }
  const std::size_t per_pose = pixels * 4;
  std::size_t both = 0, only_mine = 0, only_other = 0, over_tenth = 0;
  double max_dz = 0.0, min_dot = 1.0;
  for (std::size_t off = 0; off < mine.values.size(); off += per_pose)
    for (std::size_t k = 0; k < pixels; ++k) {
      const float a = mine.values[off + k], b = other[off + k];
      if (a > 0 && b > 0) {
        ++both;
        const double dz = std::fabs(double(a) - b);
        max_dz = std::max(max_dz, dz);
        if (dz > 0.1 * voxel_m) ++over_tenth;
        const float* na = &mine.values[off + pixels + 3 * k];
        const float* nb = &other[off + pixels + 3 * k];
        if ((na[0] != 0 || na[1] != 0 || na[2] != 0) && (nb[0] != 0 || nb[1] != 0 || nb[2] != 0))
          min_dot = std::min(min_dot, double(na[0] * nb[0] + na[1] * nb[1] + na[2] * nb[2]));
      } else if (a > 0) {
        ++only_mine;
      } else if (b > 0) {
        ++only_other;
      }
    }
  std::printf("compare with %s: hit in both %zu, only this run %zu, only the other %zu; max |dz| %.3g m (%.3f voxel), "
              "%zu pixels over 0.1 voxel; min normal dot %.5f\n",
              path.c_str(), both, only_mine, only_other, max_dz, max_dz / voxel_m, over_tenth, min_dot);
  return true;
}

const char* kUsage =
    "usage: edgefuse_tsdf_bench DATASET [--sensor NAME] [--frames N] [--voxel M] [--reps R] [--no-raycast]\n"
    "                           [--no-colour-map] [--truth] [--dump FILE] [--compare FILE] [--cast-level L]\n"
    "                           [--cast-threads N]\n"
    "  Fuses DATASET at its ground-truth poses (board defaults; --voxel sets trunc = 4 voxels), timing each\n"
    "  integration, then raycasts every pose R times (default 3) on the final volume. Thread CPU time.\n"
    "  --no-colour-map raycasts depth, vertex and normal only, as the tracking loop does.\n"
    "  --truth compares the final raycasts with the frames' own depth images (pixels off by > 1 cm).\n"
    "  --cast-level L raycasts at the tracking pyramid's level L (1: half the frames' width and height,\n"
    "  e.g. 320x240 from 640x480 frames); integration stays at full resolution. Not with --truth.\n"
    "  --cast-threads N (2..8) also casts every pose R more times on N threads (rows shared as in\n"
    "  edgefuse track --threads N) and prints wall-clock and all-thread CPU time per raycast.\n";




// What the command line asks for.
struct BenchOptions {
  Args args;
  FuseSettings s;
  int frames_max = 0, reps = 3, cast_level = 0, cast_threads = 1;
  bool cast = true;  // not --no-raycast
};

bool parse_options(int argc, char** argv, BenchOptions& o, Failure& f) {
  Args& args = o.args;
  std::string err;
  if (!args.parse(argc - 1, argv + 1, {"sensor", "frames", "voxel", "reps", "dump", "compare", "cast-level", "cast-threads"}, {"no-raycast", "no-colour-map", "truth"}, err) ||
      args.positional().size() != 1) {
    f.usage = true;
    return fail(f, err.empty() ? "expected one DATASET" : err, 2);
  }
  if (!board_fuse_settings(o.s, err) || !apply_fuse_options(args, o.s, o.frames_max, err) ||
      (args.has("reps") && !args.get_int("reps", 0, 1000, o.reps, err)) ||
      (args.has("cast-level") && !args.get_int("cast-level", 0, 3, o.cast_level, err)) ||
      (args.has("cast-threads") && !args.get_int("cast-threads", 2, 8, o.cast_threads, err)))
    return fail(f, err, 2);
  o.s.threads = 1;
  o.cast = !args.has("no-raycast");
  return true;
}

// The sequence, the core and the raycasts' sensor and maps.
struct Bench {
  io::DepthSequence seq;
  std::size_t n = 0;  // frames fused
  CoreSetup core;
  CameraSlot cam;  // the frames' sensor in slot 0
  std::vector<uint16_t> depth;
  std::vector<Rgb8> colour;
  PinholeIntrinsics cast_intr;  // the frames' own sensor, or a pyramid level's
  RaycastMaps cast_maps;
  std::size_t cast_pixels = 0;
};

bool set_up(BenchOptions& o, Bench& b, Failure& f) {
  const Args& args = o.args;
  std::string err;
  io::DepthSequence& seq = b.seq;
  if (!io::open_depth_sequence(args.positional()[0], args.get("sensor"), seq, err)) return fail(f, err);
  b.n = std::min<std::size_t>(seq.frames.size(), std::size_t(o.frames_max));
  CoreSetup& core = b.core;
  if (b.n == 0 || !core.init(build_board(), seq.intr, err) || !io::load_depth(seq.frames[0], seq.intr, b.depth, err) ||
      !centre_on_view(seq.intr, b.depth, seq.frames[0].T_world_cam, o.s, seq.frames[0].depth_path, err) ||
      !core.make_volume(o.s, err) ||
      !core.bind_camera(b.cam, 0, seq.intr, DepthSensorKind::kStructuredLight, false,
                        build_board().colour && !args.has("no-colour-map"), err))  // no colour map: as edgefuse track
    return fail(f, b.n == 0 ? "no frames" : err);
  if (o.cast_level > 0 && args.has("truth"))
    return fail(f, "--truth compares full-resolution casts only (not with --cast-level)", 2);
  // The raycasts' sensor and maps: the frames' own, or a pyramid level's (the same buffers).
  b.cast_intr = o.cast_level > 0 ? level_intrinsics(seq.intr, o.cast_level) : seq.intr;
  const int cw = b.cast_intr.width, ch = b.cast_intr.height;
  b.cast_maps = core.buffers.raycast_maps(0, cw, ch, !b.cam.maps.colour.empty());
  b.cast_pixels = std::size_t(cw) * ch;
  return true;
}

// Thread CPU time of the frames' integrations, and of a raycast after each.
struct FuseTimes {
  double integrate_ms = 0.0, raycast_fuse_ms = 0.0;
};

bool fuse_frames(const BenchOptions& o, Bench& b, FuseTimes& t, Failure& f) {
  const io::DepthSequence& seq = b.seq;
  CoreSetup& core = b.core;
  const bool use_colour = seq.colour_registered && core.volume.has_colour();
  std::string err;
  for (std::size_t i = 0; i < b.n; ++i) {
    if (!io::load_depth(seq.frames[i], seq.intr, b.depth, err) ||
        (use_colour && !io::load_colour(seq.frames[i], seq.intr, b.colour, err)))
      return fail(f, err);
    const DepthFrame fr = core.stage_frame(b.depth, use_colour ? &b.colour : nullptr);
    double t0 = thread_cpu_ms();
    integrate<real_t>(core.volume, seq.intr, b.cam.ray_norms, fr, seq.frames[i].T_world_cam, b.cam.scratch);
    t.integrate_ms += thread_cpu_ms() - t0;
    if (!o.cast) continue;
    t0 = thread_cpu_ms();
    raycast<real_t>(core.volume, b.cast_intr, seq.frames[i].T_world_cam, b.cast_maps);
    t.raycast_fuse_ms += thread_cpu_ms() - t0;
  }
  return true;
}

// A checksum of every voxel (distance, weight, colour) and brick flag: equal checksums show that
// a faster integration stores exactly the same volume.
uint64_t volume_checksum(const TsdfVolume& volume) {
  uint64_t checksum = 1469598103934665603ull;  // FNV-1a
  auto mix = [&checksum](const void* data, std::size_t bytes) {
    const unsigned char* b = static_cast<const unsigned char*>(data);
    for (std::size_t k = 0; k < bytes; ++k) checksum = (checksum ^ b[k]) * 1099511628211ull;
  };
  // Brick by brick in grid order, whatever pool slots they sit in (bricks without a slot read the
  // empty brick), so that the sum does not depend on the order bricks were first written.
  auto mix_bricks = [&](const auto* array) {
    for (std::size_t b = 0; b < volume.brick_count(); ++b) mix(array + volume.brick_base(b), kBrickVoxels * sizeof(*array));
  };
  mix_bricks(volume.tsdf());
  mix_bricks(volume.weight());
  if (volume.has_colour()) {
    mix_bricks(volume.colour());
    mix_bricks(volume.colour_weight());
  }
  mix(volume.brick_flags(), volume.brick_count());
  return checksum;
}

// The raycasts on the final volume: times, the maps of the first round, the truth comparison.
struct CastStats {
  MapDump dump;
  double raycast_ms = 0.0, prepare_ms = 0.0;
  std::size_t truth_both = 0, truth_off_1cm = 0;
  std::size_t hits = 0;
  int casts = 0;
};

// The final raycast at frame i's pose against that frame's own depth image.
bool compare_with_truth(Bench& b, std::size_t i, CastStats& c, Failure& f) {
  const io::DepthSequence& seq = b.seq;
  std::string err;
  if (!io::load_depth(seq.frames[i], seq.intr, b.depth, err)) return fail(f, err);
  const std::size_t pixels = std::size_t(seq.intr.width) * seq.intr.height;
  for (std::size_t k = 0; k < pixels; ++k) {
    const float z = b.cast_maps.depth_m.data[k], m = float(b.depth[k]) / seq.intr.depth_scale;
    if (!(z > 0.0f) || b.depth[k] == 0) continue;
    ++c.truth_both;
    c.truth_off_1cm += std::fabs(z - m) > 0.01f;
  }
  return true;
}

bool cast_final_volume(const BenchOptions& o, Bench& b, CastStats& c, Failure& f) {
  const io::DepthSequence& seq = b.seq;
  for (int r = 0; o.cast && r < o.reps; ++r)
    for (std::size_t i = 0; i < b.n; ++i) {
      double t0 = thread_cpu_ms();
      raycast<real_t>(b.core.volume, b.cast_intr, seq.frames[i].T_world_cam, b.cast_maps);
      c.raycast_ms += thread_cpu_ms() - t0;
      ++c.casts;
      if (r == 0) c.dump.add(b.cast_maps, b.cast_pixels);
      if (r == 0 && o.args.has("truth") && !compare_with_truth(b, i, c, f)) return false;
      c.hits = 0;  // of the raycast (the prepare_raycast timed below leaves its bounds in the depth map)
      for (std::size_t k = 0; k < b.cast_pixels; ++k) c.hits += b.cast_maps.depth_m.data[k] > 0.0f;
      t0 = thread_cpu_ms();
      prepare_raycast(b.core.volume, b.cast_intr, seq.frames[i].T_world_cam, b.cast_maps);
      c.prepare_ms += thread_cpu_ms() - t0;
    }
  return true;
}

void print_summary(const BenchOptions& o, const Bench& b, const FuseTimes& t, const CastStats& c, uint64_t checksum) {
  const std::size_t n = b.n;
  std::printf("%s %dx%d, %d^3 x %.4g m (%s), %zu frames: integrate %.2f ms/frame thread CPU", b.seq.root.c_str(),
              b.seq.intr.width, b.seq.intr.height, o.s.dim, double(o.s.voxel_m),
              std::is_same<real_t, float>::value ? "float" : "Q16.16", n, t.integrate_ms / n);
  if (o.cast && o.cast_level > 0)
    std::printf(", raycasts %dx%d (pyramid level %d)", b.cast_intr.width, b.cast_intr.height, o.cast_level);
  if (o.cast)
    std::printf(", raycast %.2f ms after each frame, %.2f ms on the final volume (%d casts; of which prepare %.2f ms), "
                "hit %.1f%% (last)",
                t.raycast_fuse_ms / n, c.raycast_ms / std::max(c.casts, 1), c.casts, c.prepare_ms / std::max(c.casts, 1),
                100.0 * c.hits / b.cast_pixels);
  std::printf("\nvolume checksum %016llx\n%s\n", static_cast<unsigned long long>(checksum),
              b.core.space_usage().c_str());
}

// The same casts spread over a worker pool (started here, before the timed loop): wall clock
// per raycast, and the CPU time of all threads, which shows what the split costs.
void cast_on_threads(const BenchOptions& o, Bench& b) {
  PoolRunners threads;
  threads.start(o.cast_threads);
  double wall_ms = 0.0, cpu_ms = 0.0;
  int parallel_casts = 0;
  for (int r = 0; r < o.reps; ++r)
    for (std::size_t i = 0; i < b.n; ++i) {
      const double w0 = clock_ms(CLOCK_MONOTONIC), c0 = clock_ms(CLOCK_PROCESS_CPUTIME_ID);
      raycast_frame<real_t>(threads.runners().tsdf, b.core.volume, b.cast_intr, b.seq.frames[i].T_world_cam,
                            b.cast_maps);
      wall_ms += clock_ms(CLOCK_MONOTONIC) - w0;
      cpu_ms += clock_ms(CLOCK_PROCESS_CPUTIME_ID) - c0;
      ++parallel_casts;
    }
  threads.pool.stop();
  std::printf("raycast on %d threads: %.2f ms wall, %.2f ms CPU of all threads per raycast (%d casts)\n",
              o.cast_threads, wall_ms / std::max(parallel_casts, 1), cpu_ms / std::max(parallel_casts, 1),
              parallel_casts);
}

bool write_dump(const std::string& path, const MapDump& dump, Failure& f) {
  FILE* fp = std::fopen(path.c_str(), "wb");
  if (fp == nullptr || std::fwrite(dump.values.data(), sizeof(float), dump.values.size(), fp) != dump.values.size()) {
    if (fp != nullptr) std::fclose(fp);
    return fail(f, "cannot write --dump file " + path);
  }
  std::fclose(fp);
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  BenchOptions o;
  Failure f;
  Bench b;
  FuseTimes t;
  CastStats c;
  if (!parse_options(argc, argv, o, f) || !set_up(o, b, f) || !fuse_frames(o, b, t, f)) return report("edgefuse_tsdf_bench", f, kUsage);
  const uint64_t checksum = volume_checksum(b.core.volume);
  if (!cast_final_volume(o, b, c, f)) return report("edgefuse_tsdf_bench", f, kUsage);
  print_summary(o, b, t, c, checksum);
  if (o.cast && o.cast_threads > 1) cast_on_threads(o, b);
  if (o.args.has("truth"))
    std::printf("against the frames' depth: %zu pixels with both, %zu off by more than 1 cm\n", c.truth_both,
                c.truth_off_1cm);
  if (o.args.has("dump") && !write_dump(o.args.get("dump"), c.dump, f)) return report("edgefuse_tsdf_bench", f, kUsage);
  if (o.args.has("compare") && !compare_dumps(c.dump, o.args.get("compare"), b.cast_pixels, o.s.voxel_m)) return 1;
  return 0;
}
