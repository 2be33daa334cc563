#include "edgefuse/hal/platform/threads/worker_pool.hpp"

namespace edgefuse {

void WorkerPool::start(int threads) {
  stop();
  stopping_ = false;
  for (int i = 1; i < threads; ++i) threads_.emplace_back([this, i] { loop(i); });
}

void WorkerPool::run(Task task, void* context) {
  const int workers = size();
  if (workers > 1) {
    std::lock_guard<std::mutex> lock(mutex_);
    task_ = task;
    context_ = context;
    pending_ = workers - 1;
    ++generation_;
    wake_.notify_all();
  }
  task(context, 0, workers);
  if (workers > 1) {
    std::unique_lock<std::mutex> lock(mutex_);
    done_.wait(lock, [this] { return pending_ == 0; });
  }
}

void WorkerPool::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
    wake_.notify_all();
  }
  for (std::thread& t : threads_) t.join();
  threads_.clear();
}

void WorkerPool::loop(int worker) {
  uint64_t seen = 0;
  for (;;) {
    Task task;
    void* context;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [&] { return stopping_ || generation_ != seen; });
      if (stopping_) return;
      seen = generation_;
      task = task_;
      context = context_;
    }
    task(context, worker, size());
    std::lock_guard<std::mutex> lock(mutex_);
    if (--pending_ == 0) done_.notify_one();
  }
}

}  // namespace edgefuse
