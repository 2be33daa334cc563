// edgefuse acquire [--board NAME] [--seconds S] [--replay DATASET] [--fault KIND] [--fault-at S]
// Runs the acquisition runtime on the devices of board/<NAME>/hal.toml (default: the build board;
// host-sim = the simulated rig): one thread per camera, frames through the static pools, the first
// two cameras paired by stamp. Prints every camera's status counters each second and a summary.
// --fault stall|drop|garbage|unplug injects that fault into the first camera at --fault-at
// seconds (an unplugged camera is replugged one second later) to show the recovery.
#include <chrono>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <thread>

#include "args.hpp"
#include "commands.hpp"
#include "edgefuse/board_config.hpp"
#include "edgefuse/io/board_hal.hpp"
#include "edgefuse/memory/arena.hpp"
#include "edgefuse/hal/acquisition/camera_worker.hpp"
#include "edgefuse/hal/acquisition/frame_pairer.hpp"
#include "edgefuse/hal/acquisition/frame_pool.hpp"
#include "edgefuse/hal/acquisition/scanner_worker.hpp"
#include "edgefuse/hal/devices/hal_devices.hpp"
#include "edgefuse/hal/platform/clock/monotonic_clock.hpp"

namespace edgefuse::cli {

namespace {
constexpr int kMaxCameras = 3;
// Frame pools: the memory map's "acquisition pools" regions (one pool of kFramePoolSlots frames
// of the build board's largest image per sensor); only the small frame views live here.
hal::FramePoolViews g_pool_views[kMaxCameras];
hal::AcquisitionCounters g_counters[kMaxCameras];
hal::FrameChannel g_channels[kMaxCameras];
// The line scanner's profiles (up to 1024 beams), 15 slots drained every 2 ms: every profile is kept.
hal::ProfileChannelStorage<1024, 15> g_profile_pool;
hal::AcquisitionCounters g_profile_counters;
hal::ProfileChannel g_profiles;

int usage(const char* why) {
  std::fprintf(stderr,
               "edgefuse acquire: %s\nusage: edgefuse acquire [--board NAME] [--seconds S] [--replay DATASET] "
               "[--fault stall|drop|garbage|unplug] [--fault-at S]\n",
               why);
  return 2;
}
}  // namespace

int cmd_acquire(int argc, char** argv) {
  Args args;
  std::string err;
  if (!args.parse(argc, argv, {"board", "seconds", "replay", "fault", "fault-at"}, {}, err))
    return usage(err.c_str());
  if (!args.positional().empty()) return usage("unexpected argument");
  int seconds = 5;
  float fault_at = 2.0f;
  if (!args.get_int("seconds", 1, 86400, seconds, err) || !args.get_float("fault-at", 0, 86400, fault_at, err))
    return usage(err.c_str());
  const std::string fault = args.get("fault");
  if (!fault.empty() && fault != "stall" && fault != "drop" && fault != "garbage" && fault != "unplug")
    return usage(("--fault '" + fault + "' is not stall, drop, garbage or unplug").c_str());
  const std::string board = args.get("board", build_board().name);
  const std::string path = std::string(kBoardSourceDir) + "/" + board + "/hal.toml";
  io::BoardHal hal_data;
  if (!io::read_board_hal(path, hal_data, err)) {
    std::fprintf(stderr, "edgefuse acquire: %s\n", err.c_str());
    return 1;
  }
  hal::MonotonicClock& clock = hal::monotonic_clock();
  hal::HalDevices devices;
  // --fault: the cameras are wrapped in FaultCameras (only then).
  if (!devices.build(hal_data, clock, err, args.get("replay"), true, 1.0, !fault.empty())) {
    std::fprintf(stderr, "edgefuse acquire: %s: %s\n", path.c_str(), err.c_str());
    return 1;
  }
  CoreBuffers buffers;  // the static arena, carved once (only its frame pools are used here)
  if (carve_memory(build_board(), static_arena(), static_arena_bytes(), buffers) != Status::kOk) {
    std::fprintf(stderr, "edgefuse acquire: the static arena does not hold board %s's memory map\n",
                 build_board().name);
    return 1;
  }
  const int pools = buffers.frame_pools.pools < kMaxCameras ? buffers.frame_pools.pools : kMaxCameras;
  const int n = devices.camera_count() < pools ? devices.camera_count() : pools;
  if (n == 0) {
    std::fprintf(stderr, "edgefuse acquire: %s lists no [[camera]]\n", path.c_str());
    return 1;
  }
  if (devices.camera_count() > n)
    std::fprintf(stderr, "edgefuse acquire: %s lists %d cameras; the first %d have frame pools (sensors_max)\n",
                 path.c_str(), devices.camera_count(), n);
  std::printf("board %s: %d camera(s), backends built: %s, frame pools %d x %d px x %d slots (memory map)\n",
              board.c_str(), n, hal::HalDevices::built_backends(), kBuildBoard.image_width_max,
              kBuildBoard.image_height_max, kFramePoolSlots);
  std::unique_ptr<hal::CameraWorker> workers[kMaxCameras];
  for (int i = 0; i < n; ++i) {
    if (!hal::bind_frame_pool(buffers.frame_pools, i, g_pool_views[i], g_channels[i], g_counters[i])) {
      std::fprintf(stderr, "edgefuse acquire: no frame pool %d in the memory map\n", i);
      return 1;
    }
    workers[i].reset(new hal::CameraWorker(devices.camera(i), g_channels[i], g_counters[i], clock, &devices.monitor()));
    hal::CameraWorkerConfig wc;
    if (!workers[i]->start(wc)) {
      std::fprintf(stderr, "edgefuse acquire: cannot start the thread of camera '%s'\n", devices.camera(i).name());
      return 1;
    }
  }
  std::unique_ptr<hal::ScannerWorker> scanner_worker;
  long profiles = 0;
  hal::LineScanner* scanner = devices.scanner();
  if (scanner != nullptr) {
    if (scanner->info().beams > 1024) {
      std::fprintf(stderr, "edgefuse acquire: line scanner '%s' has %d beams, more than 1024\n", scanner->name(),
                   scanner->info().beams);
      return 1;
    }
    g_profile_pool.bind(g_profiles, g_profile_counters);
    scanner_worker.reset(new hal::ScannerWorker(*scanner, g_profiles, g_profile_counters));
    scanner_worker->start(hal::ScannerWorkerConfig{});
  }
  hal::FramePairer pairer(g_channels[0], g_channels[n > 1 ? 1 : 0], 20000);
  const auto t0 = std::chrono::steady_clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  long taken[kMaxCameras] = {};
  bool fault_done = fault.empty(), replugged = fault != "unplug";
  int next_report = 1;
  while (elapsed() < seconds) {
    if (n > 1) {
      hal::FramePair p;
      if (pairer.poll(p)) {
        ++taken[0];
        ++taken[1];
        pairer.release(p);
      }
      for (int i = 2; i < n; ++i)
        if (const hal::DepthFrame* f = g_channels[i].acquire_newest()) {
          ++taken[i];
          g_channels[i].release(f);
        }
    } else if (const hal::DepthFrame* f = g_channels[0].acquire_newest()) {
      ++taken[0];
      g_channels[0].release(f);
    }
    profiles += g_profiles.drain([](const hal::LineProfile&) {});
    if (!fault_done && elapsed() >= fault_at) {
      hal::FaultCamera& cam = *devices.faults(0);
      if (fault == "stall") cam.inject_stall(1500);
      if (fault == "drop") cam.inject_drop(5);
      if (fault == "garbage") cam.inject_garbage(hal::GarbageKind::kAllInvalid);
      if (fault == "unplug") cam.set_plugged(false);
      std::printf("%.1f s: injected %s into '%s'\n", elapsed(), fault.c_str(), cam.name());
      fault_done = true;
    }
    if (!replugged && elapsed() >= fault_at + 1.0) {
      devices.faults(0)->set_plugged(true);
      std::printf("%.1f s: replugged '%s'\n", elapsed(), devices.camera(0).name());
      replugged = true;
    }
    if (elapsed() >= next_report) {
      for (int i = 0; i < n; ++i) {
        char line[512];
        hal::format_counters(g_counters[i], line, sizeof(line));
        std::printf("%d s %-6s %s taken=%ld\n", next_report, devices.camera(i).name(), line, taken[i]);
      }
      if (scanner != nullptr) {
        char line[512];
        hal::format_counters(g_profile_counters, line, sizeof(line));
        std::printf("%d s %-6s %s taken=%ld\n", next_report, scanner->name(), line, profiles);
      }
      ++next_report;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  for (int i = 0; i < n; ++i) workers[i]->stop();
  if (scanner_worker) scanner_worker->stop();
  profiles += g_profiles.drain([](const hal::LineProfile&) {});
  pairer.reset();
  for (int i = 0; i < n; ++i) {
    char line[512];
    hal::format_counters(g_counters[i], line, sizeof(line));
    std::printf("end %-6s %s taken=%ld\n", devices.camera(i).name(), line, taken[i]);
  }
  if (scanner != nullptr) {
    char line[512];
    hal::format_counters(g_profile_counters, line, sizeof(line));
    std::printf("end %-6s %s taken=%ld\n", scanner->name(), line, profiles);
  }
  long total = 0;
  for (int i = 0; i < n; ++i) total += taken[i];
  std::printf("cameras=%d frames_taken=%ld pairs=%u unpaired=%u profiles=%ld\n", n, total,
              n > 1 ? pairer.pairs() : 0u, n > 1 ? pairer.unpaired_a() + pairer.unpaired_b() : 0u, profiles);
  return total > 0 ? 0 : 1;
}

}  // namespace edgefuse::cli
