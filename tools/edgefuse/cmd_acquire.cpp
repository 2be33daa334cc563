// edgefuse acquire [--board NAME] [--board-dir DIR] [--seconds S] [--replay DATASET] [--fault KIND] [--fault-at S]
// Runs the acquisition runtime on the devices of <board data>/<NAME>/hal.toml (default: the build board;
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
#include "failure.hpp"
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
#include "edgefuse/hal/platform/config/board_data_dir.hpp"

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

const char* kUsage =
    "usage: edgefuse acquire [--board NAME] [--board-dir DIR] [--seconds S] [--replay DATASET] "
    "[--fault stall|drop|garbage|unplug] [--fault-at S]\n";

// What the command line asks for.
struct AcquireOptions {
  Args args;
  int seconds = 5;
  float fault_at = 2.0f;
  std::string fault;  // empty: none
  std::string board;
  std::string path;  // the board's hal.toml
};

// A malformed command line: exit code 2, the usage follows the message.
bool bad_usage(Failure& f, const std::string& why) {
  f.usage = true;
  return fail(f, why, 2);
}

bool parse_options(int argc, char** argv, AcquireOptions& o, Failure& f) {
  std::string err;
  if (!o.args.parse(argc, argv, {"board", "board-dir", "seconds", "replay", "fault", "fault-at"}, {}, err)) return bad_usage(f, err);
  if (!o.args.positional().empty()) return bad_usage(f, "unexpected argument");
  if (!o.args.get_int("seconds", 1, 86400, o.seconds, err) || !o.args.get_float("fault-at", 0, 86400, o.fault_at, err))
    return bad_usage(f, err);
  o.fault = o.args.get("fault");
  if (!o.fault.empty() && o.fault != "stall" && o.fault != "drop" && o.fault != "garbage" && o.fault != "unplug")
    return bad_usage(f, "--fault '" + o.fault + "' is not stall, drop, garbage or unplug");
  o.board = o.args.get("board", build_board().name);
  hal::set_board_data_dir(o.args.get("board-dir"));
  return hal::board_file_path(o.board, "hal.toml", o.path, err) || fail(f, err);
}

// The devices, the frame pools, the workers that fill them and what the loop took. Declared in
// the order they are built: the workers stop (destructors) before the devices they read go.
struct AcquireRun {
  io::BoardHal hal_data;
  hal::HalDevices devices;
  CoreBuffers buffers;  // the static arena, carved once (only its frame pools are used here)
  int n = 0;            // cameras with a frame pool
  std::unique_ptr<hal::CameraWorker> workers[kMaxCameras];
  std::unique_ptr<hal::ScannerWorker> scanner_worker;
  hal::LineScanner* scanner = nullptr;
  long taken[kMaxCameras] = {};
  long profiles = 0;
};

bool build_devices(const AcquireOptions& o, AcquireRun& run, Failure& f) {
  std::string err;
  if (!io::read_board_hal(o.path, run.hal_data, err)) return fail(f, err);
  // --fault: the cameras are wrapped in FaultCameras (only then).
  if (!run.devices.build(run.hal_data, hal::monotonic_clock(), err, o.args.get("replay"), true, 1.0, !o.fault.empty()))
    return fail(f, o.path + ": " + err);
  return true;
}

// One worker thread per camera that has a frame pool in the memory map.
bool start_cameras(const AcquireOptions& o, AcquireRun& run, Failure& f) {
  hal::HalDevices& devices = run.devices;
  if (carve_memory(build_board(), static_arena(), static_arena_bytes(), run.buffers) != Status::kOk)
    return fail(f, "the static arena does not hold board " + std::string(build_board().name) + "'s memory map");
  const int pools = run.buffers.frame_pools.pools < kMaxCameras ? run.buffers.frame_pools.pools : kMaxCameras;
  const int n = devices.camera_count() < pools ? devices.camera_count() : pools;
  run.n = n;
  if (n == 0) return fail(f, o.path + " lists no [[camera]]");
  if (devices.camera_count() > n)
    std::fprintf(stderr, "edgefuse acquire: %s lists %d cameras; the first %d have frame pools (sensors_max)\n",
                 o.path.c_str(), devices.camera_count(), n);
  std::printf("board %s: %d camera(s), backends built: %s, frame pools %d x %d px x %d slots (memory map)\n",
              o.board.c_str(), n, hal::HalDevices::built_backends(), kBuildBoard.image_width_max,
              kBuildBoard.image_height_max, kFramePoolSlots);
  for (int i = 0; i < n; ++i) {
    if (!hal::bind_frame_pool(run.buffers.frame_pools, i, g_pool_views[i], g_channels[i], g_counters[i]))
      return fail(f, "no frame pool " + std::to_string(i) + " in the memory map");
    run.workers[i].reset(new hal::CameraWorker(devices.camera(i), g_channels[i], g_counters[i], hal::monotonic_clock(),
                                               &devices.monitor()));
    hal::CameraWorkerConfig wc;
    if (!run.workers[i]->start(wc))
      return fail(f, "cannot start the thread of camera '" + std::string(devices.camera(i).name()) + "'");
  }
  return true;
}

bool start_scanner(AcquireRun& run, Failure& f) {
  run.scanner = run.devices.scanner();
  if (run.scanner == nullptr) return true;
  if (run.scanner->info().beams > 1024)
    return fail(f, "line scanner '" + std::string(run.scanner->name()) + "' has " +
                       std::to_string(run.scanner->info().beams) + " beams, more than 1024");
  g_profile_pool.bind(g_profiles, g_profile_counters);
  run.scanner_worker.reset(new hal::ScannerWorker(*run.scanner, g_profiles, g_profile_counters));
  run.scanner_worker->start(hal::ScannerWorkerConfig{});
  return true;
}

// Seconds since the loop started.
struct Stopwatch {
  std::chrono::steady_clock::time_point t0 = std::chrono::steady_clock::now();
  double seconds() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); }
};

// The newest frame of every camera (the first two as stamp pairs) and the scanner's profiles, counted.
void take_frames(AcquireRun& run, hal::FramePairer& pairer) {
  if (run.n > 1) {
    hal::FramePair p;
    if (pairer.poll(p)) {
      ++run.taken[0];
      ++run.taken[1];
      pairer.release(p);
    }
    for (int i = 2; i < run.n; ++i)
      if (const hal::DepthFrame* f = g_channels[i].acquire_newest()) {
        ++run.taken[i];
        g_channels[i].release(f);
      }
  } else if (const hal::DepthFrame* f = g_channels[0].acquire_newest()) {
    ++run.taken[0];
    g_channels[0].release(f);
  }
  run.profiles += g_profiles.drain([](const hal::LineProfile&) {});
}

void inject_fault(const std::string& fault, AcquireRun& run, const Stopwatch& clock) {
  hal::FaultCamera& cam = *run.devices.faults(0);
  if (fault == "stall") cam.inject_stall(1500);
  if (fault == "drop") cam.inject_drop(5);
  if (fault == "garbage") cam.inject_garbage(hal::GarbageKind::kAllInvalid);
  if (fault == "unplug") cam.set_plugged(false);
  std::printf("%.1f s: injected %s into '%s'\n", clock.seconds(), fault.c_str(), cam.name());
}

// Every camera's and the scanner's status counters and what was taken, each line led by `when`.
void print_counters(AcquireRun& run, const char* when) {
  for (int i = 0; i < run.n; ++i) {
    char line[512];
    hal::format_counters(g_counters[i], line, sizeof(line));
    std::printf("%s %-6s %s taken=%ld\n", when, run.devices.camera(i).name(), line, run.taken[i]);
  }
  if (run.scanner != nullptr) {
    char line[512];
    hal::format_counters(g_profile_counters, line, sizeof(line));
    std::printf("%s %-6s %s taken=%ld\n", when, run.scanner->name(), line, run.profiles);
  }
}

// The loop for --seconds: takes frames, injects the fault when due, reports each second.
void take_for(const AcquireOptions& o, AcquireRun& run, hal::FramePairer& pairer) {
  const Stopwatch clock;
  bool fault_done = o.fault.empty(), replugged = o.fault != "unplug";
  int next_report = 1;
  while (clock.seconds() < o.seconds) {
    take_frames(run, pairer);
    if (!fault_done && clock.seconds() >= o.fault_at) {
      inject_fault(o.fault, run, clock);
      fault_done = true;
    }
    if (!replugged && clock.seconds() >= o.fault_at + 1.0) {
      run.devices.faults(0)->set_plugged(true);
      std::printf("%.1f s: replugged '%s'\n", clock.seconds(), run.devices.camera(0).name());
      replugged = true;
    }
    if (clock.seconds() >= next_report) {
      char when[16];
      std::snprintf(when, sizeof(when), "%d s", next_report);
      print_counters(run, when);
      ++next_report;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
}

// Runs the loop, stops the workers and prints the summary; 0 when frames came.
int acquire(const AcquireOptions& o, AcquireRun& run) {
  hal::FramePairer pairer(g_channels[0], g_channels[run.n > 1 ? 1 : 0], 20000);
  take_for(o, run, pairer);
  for (int i = 0; i < run.n; ++i) run.workers[i]->stop();
  if (run.scanner_worker) run.scanner_worker->stop();
  run.profiles += g_profiles.drain([](const hal::LineProfile&) {});
  pairer.reset();
  print_counters(run, "end");
  long total = 0;
  for (int i = 0; i < run.n; ++i) total += run.taken[i];
  const int n = run.n;
  std::printf("cameras=%d frames_taken=%ld pairs=%u unpaired=%u profiles=%ld\n", n, total,
              n > 1 ? pairer.pairs() : 0u, n > 1 ? pairer.unpaired_a() + pairer.unpaired_b() : 0u, run.profiles);
  return total > 0 ? 0 : 1;
}

}  // namespace

int cmd_acquire(int argc, char** argv) {
  if (help_asked(argc, argv, kUsage)) return 0;
  AcquireOptions o;
  Failure f;
  AcquireRun run;
  if (!parse_options(argc, argv, o, f) || !build_devices(o, run, f) || !start_cameras(o, run, f) ||
      !start_scanner(run, f))
    return report("edgefuse acquire", f, kUsage);
  return acquire(o, run);
}

}  // namespace edgefuse::cli
