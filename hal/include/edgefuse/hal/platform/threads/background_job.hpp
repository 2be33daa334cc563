// One job on its own thread, run on request: the firmware's localisation (hundreds of milliseconds)
// runs there so the console and the link stay served. The thread is created once at start-up;
// submit(), finished() and collect() allocate nothing.
#pragma once

#include <atomic>
#include <condition_variable>
#include <mutex>
#include <thread>

namespace edgefuse::hal {

class BackgroundJob {
 public:
  using Job = void (*)(void* context);
  BackgroundJob() = default;
  ~BackgroundJob() { stop(); }
  BackgroundJob(const BackgroundJob&) = delete;
  BackgroundJob& operator=(const BackgroundJob&) = delete;

  //! Starts the thread (start-up: this allocates). \param job the work \param context its argument
  void start(Job job, void* context);
  //! Runs the job once more. \return false while a run is not collected yet
  bool submit();
  //! A submitted run is not collected yet (running, or finished and waiting).
  bool busy() const { return busy_; }
  //! The submitted run has ended (its results may be read until collect()).
  bool finished() const { return busy_ && done_; }
  //! Marks the finished run as read: the next submit() may start.
  void collect() { busy_ = false; }
  //! Ends the thread after the current run (idempotent).
  void stop();

 private:
  void loop();

  Job job_ = nullptr;
  void* context_ = nullptr;
  std::thread thread_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool quit_ = false;
  bool request_ = false;
  std::atomic<bool> busy_{false};
  std::atomic<bool> done_{false};
};

}  // namespace edgefuse::hal
