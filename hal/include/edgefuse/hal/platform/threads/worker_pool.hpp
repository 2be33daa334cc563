// A fixed set of worker threads, created once at start-up, that run one job at a time across all
// workers (the calling thread is worker 0). run() allocates nothing, so the core's kernels can be
// spread over the board's cores in steady state.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <thread>
#include <vector>

namespace edgefuse {

class WorkerPool {
 public:
  //! A job: called once per worker with its index in [0, workers).
  using Task = void (*)(void* context, int worker, int workers);

  WorkerPool() = default;
  ~WorkerPool() { stop(); }
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  //! Starts `threads - 1` helper threads (start-up only: this allocates).
  //! \param threads total workers including the caller, >= 1
  void start(int threads);
  //! Runs `task` on every worker and returns when all have finished.
  //! \param task the job  \param context passed to every call
  void run(Task task, void* context);
  //! Joins the helper threads.
  void stop();
  int size() const { return int(threads_.size()) + 1; }

 private:
  void loop(int worker);

  std::vector<std::thread> threads_;
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  Task task_ = nullptr;
  void* context_ = nullptr;
  uint64_t generation_ = 0;
  int pending_ = 0;
  bool stopping_ = false;
};

}  // namespace edgefuse
