#include "edgefuse/hal/platform/threads/background_job.hpp"

namespace edgefuse::hal {

void BackgroundJob::start(Job job, void* context) {
  job_ = job;
  context_ = context;
  quit_ = false;
  thread_ = std::thread([this] { loop(); });
}

bool BackgroundJob::submit() {
  if (busy_) return false;
  done_ = false;
  busy_ = true;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    request_ = true;
  }
  wake_.notify_one();
  return true;
}

void BackgroundJob::stop() {
  if (!thread_.joinable()) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    quit_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

void BackgroundJob::loop() {
  for (;;) {
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [this] { return quit_ || request_; });
      if (quit_) return;
      request_ = false;
    }
    job_(context_);
    done_ = true;
  }
}

}  // namespace edgefuse::hal
