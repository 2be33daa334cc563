// Benchmark of the TSDF kernels alone (speed work, round 3): fuses a sequence at its ground-truth
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

#include "args.hpp"
#include "core_setup.hpp"
#include "edgefuse/io/dataset.hpp"
#include "edgefuse/memory/arena.hpp"
#include "edgefuse/tracking/pyramid.hpp"
#include "fuse_options.hpp"
#include "edgefuse/hal/platform/threads/parallel_tsdf.hpp"

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

}  // namespace

int main(int argc, char** argv) {
  Args args;
  std::string err;
  if (!args.parse(argc - 1, argv + 1, {"sensor", "frames", "voxel", "reps", "dump", "compare", "cast-level", "cast-threads"}, {"no-raycast", "no-colour-map", "truth"}, err) ||
      args.positional().size() != 1) {
    std::fprintf(stderr, "edgefuse_tsdf_bench: %s\n%s", err.empty() ? "expected one DATASET" : err.c_str(), kUsage);
    return 2;
  }
  const BoardCapacities& board = build_board();
  FuseSettings s;
  int frames_max = 0, reps = 3, cast_level = 0, cast_threads = 1;
  if (!board_fuse_settings(s, err) || !apply_fuse_options(args, s, frames_max, err) ||
      (args.has("reps") && !args.get_int("reps", 0, 1000, reps, err)) ||
      (args.has("cast-level") && !args.get_int("cast-level", 0, 3, cast_level, err)) ||
      (args.has("cast-threads") && !args.get_int("cast-threads", 2, 8, cast_threads, err))) {
    std::fprintf(stderr, "edgefuse_tsdf_bench: %s\n", err.c_str());
    return 2;
  }
  s.threads = 1;
  io::DepthSequence seq;
  if (!io::open_depth_sequence(args.positional()[0], args.get("sensor"), seq, err)) {
    std::fprintf(stderr, "edgefuse_tsdf_bench: %s\n", err.c_str());
    return 1;
  }
  const std::size_t n = std::min<std::size_t>(seq.frames.size(), std::size_t(frames_max));
  CoreSetup core;
  std::vector<uint16_t> depth;
  std::vector<Rgb8> colour;
  if (n == 0 || !core.init(board, seq.intr, err) || !io::load_depth(seq.frames[0], seq.intr, depth, err) ||
      !centre_on_view(seq.intr, depth, seq.frames[0].T_world_cam, s, seq.frames[0].depth_path, err) ||
      !core.make_volume(s, err)) {
    std::fprintf(stderr, "edgefuse_tsdf_bench: %s\n", n == 0 ? "no frames" : err.c_str());
    return 1;
  }
  const bool use_colour = seq.colour_registered && core.volume.has_colour();
  const int W = seq.intr.width, H = seq.intr.height;
  const std::size_t pixels = std::size_t(W) * H;
  double integrate_ms = 0.0, raycast_fuse_ms = 0.0;
  const bool cast = !args.has("no-raycast");
  if (args.has("no-colour-map")) core.maps.colour = ImageView<Rgba8>();  // as edgefuse track
  if (cast_level > 0 && args.has("truth")) {
    std::fprintf(stderr, "edgefuse_tsdf_bench: --truth compares full-resolution casts only (not with --cast-level)\n");
    return 2;
  }
  // The raycasts' sensor and maps: the frames' own, or a pyramid level's (the same buffers).
  const PinholeIntrinsics cast_intr = cast_level > 0 ? level_intrinsics(seq.intr, cast_level) : seq.intr;
  const int cw = cast_intr.width, ch = cast_intr.height;
  const RaycastMaps cast_maps = core.buffers.raycast_maps(0, cw, ch, !core.maps.colour.empty());
  const std::size_t cast_pixels = std::size_t(cw) * ch;
  for (std::size_t i = 0; i < n; ++i) {
    if (!io::load_depth(seq.frames[i], seq.intr, depth, err) ||
        (use_colour && !io::load_colour(seq.frames[i], seq.intr, colour, err))) {
      std::fprintf(stderr, "edgefuse_tsdf_bench: %s\n", err.c_str());
      return 1;
    }
    const DepthFrame f = core.stage_frame(depth, use_colour ? &colour : nullptr);
    double t0 = thread_cpu_ms();
    integrate<real_t>(core.volume, seq.intr, ImageView<const real_t>(core.ray_norms.data, W, H), f,
                      seq.frames[i].T_world_cam, core.scratch);
    integrate_ms += thread_cpu_ms() - t0;
    if (!cast) continue;
    t0 = thread_cpu_ms();
    raycast<real_t>(core.volume, cast_intr, seq.frames[i].T_world_cam, cast_maps);
    raycast_fuse_ms += thread_cpu_ms() - t0;
  }
  // A checksum of every voxel (distance, weight, colour) and brick flag: equal checksums show that
  // a faster integration stores exactly the same volume.
  uint64_t checksum = 1469598103934665603ull;  // FNV-1a
  auto mix = [&checksum](const void* data, std::size_t bytes) {
    const unsigned char* b = static_cast<const unsigned char*>(data);
    for (std::size_t k = 0; k < bytes; ++k) checksum = (checksum ^ b[k]) * 1099511628211ull;
  };
  const std::size_t voxels = core.volume.voxel_count();
  mix(core.volume.tsdf(), voxels * sizeof(int16_t));
  mix(core.volume.weight(), voxels);
  if (core.volume.has_colour()) {
    mix(core.volume.colour(), voxels * sizeof(Rgb8));
    mix(core.volume.colour_weight(), voxels);
  }
  mix(core.volume.brick_flags(), core.volume.brick_count());
  MapDump dump;
  double raycast_ms = 0.0, prepare_ms = 0.0;
  std::size_t truth_both = 0, truth_off_1cm = 0;
  std::size_t hits = 0;
  int casts = 0;
  for (int r = 0; cast && r < reps; ++r)
    for (std::size_t i = 0; i < n; ++i) {
      double t0 = thread_cpu_ms();
      raycast<real_t>(core.volume, cast_intr, seq.frames[i].T_world_cam, cast_maps);
      raycast_ms += thread_cpu_ms() - t0;
      ++casts;
      if (r == 0) dump.add(cast_maps, cast_pixels);
      if (r == 0 && args.has("truth")) {
        // The final raycast at a frame's pose against that frame's own depth image.
        if (!io::load_depth(seq.frames[i], seq.intr, depth, err)) {
          std::fprintf(stderr, "edgefuse_tsdf_bench: %s\n", err.c_str());
          return 1;
        }
        for (std::size_t k = 0; k < pixels; ++k) {
          const float z = cast_maps.depth_m.data[k], m = float(depth[k]) / seq.intr.depth_scale;
          if (!(z > 0.0f) || depth[k] == 0) continue;
          ++truth_both;
          truth_off_1cm += std::fabs(z - m) > 0.01f;
        }
      }
      hits = 0;  // of the raycast (the prepare_raycast timed below leaves its bounds in the depth map)
      for (std::size_t k = 0; k < cast_pixels; ++k) hits += cast_maps.depth_m.data[k] > 0.0f;
      t0 = thread_cpu_ms();
      prepare_raycast(core.volume, cast_intr, seq.frames[i].T_world_cam, cast_maps);
      prepare_ms += thread_cpu_ms() - t0;
    }
  std::printf("%s %dx%d, %d^3 x %.4g m (%s), %zu frames: integrate %.2f ms/frame thread CPU", seq.root.c_str(), W, H,
              s.dim, double(s.voxel_m), std::is_same<real_t, float>::value ? "float" : "Q16.16", n, integrate_ms / n);
  if (cast && cast_level > 0) std::printf(", raycasts %dx%d (pyramid level %d)", cw, ch, cast_level);
  if (cast)
    std::printf(", raycast %.2f ms after each frame, %.2f ms on the final volume (%d casts; of which prepare %.2f ms), "
                "hit %.1f%% (last)",
                raycast_fuse_ms / n, raycast_ms / std::max(casts, 1), casts, prepare_ms / std::max(casts, 1),
                100.0 * hits / cast_pixels);
  std::printf("\nvolume checksum %016llx\n", static_cast<unsigned long long>(checksum));
  if (cast && cast_threads > 1) {
    // The same casts spread over a worker pool (started here, before the timed loop): wall clock
    // per raycast, and the CPU time of all threads, which shows what the split costs.
    WorkerPool pool;
    pool.start(cast_threads);
    double wall_ms = 0.0, cpu_ms = 0.0;
    int parallel_casts = 0;
    for (int r = 0; r < reps; ++r)
      for (std::size_t i = 0; i < n; ++i) {
        const double w0 = clock_ms(CLOCK_MONOTONIC), c0 = clock_ms(CLOCK_PROCESS_CPUTIME_ID);
        raycast_parallel<real_t>(pool, core.volume, cast_intr, seq.frames[i].T_world_cam, cast_maps);
        wall_ms += clock_ms(CLOCK_MONOTONIC) - w0;
        cpu_ms += clock_ms(CLOCK_PROCESS_CPUTIME_ID) - c0;
        ++parallel_casts;
      }
    pool.stop();
    std::printf("raycast on %d threads: %.2f ms wall, %.2f ms CPU of all threads per raycast (%d casts)\n", cast_threads,
                wall_ms / std::max(parallel_casts, 1), cpu_ms / std::max(parallel_casts, 1), parallel_casts);
  }
  if (args.has("truth"))
    std::printf("against the frames' depth: %zu pixels with both, %zu off by more than 1 cm\n", truth_both,
                truth_off_1cm);
  if (args.has("dump")) {
    FILE* fp = std::fopen(args.get("dump").c_str(), "wb");
    if (fp == nullptr || std::fwrite(dump.values.data(), sizeof(float), dump.values.size(), fp) != dump.values.size()) {
      std::fprintf(stderr, "edgefuse_tsdf_bench: cannot write --dump file %s\n", args.get("dump").c_str());
      if (fp != nullptr) std::fclose(fp);
      return 1;
    }
    std::fclose(fp);
  }
  if (args.has("compare") && !compare_dumps(dump, args.get("compare"), cast_pixels, s.voxel_m)) return 1;
  return 0;
}
