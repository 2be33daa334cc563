#include "edgefuse/hal/platform/threads/pool_parallel_for.hpp"

#include <atomic>

namespace edgefuse {

namespace {

struct PoolJobs {
  std::atomic<std::size_t> next{0};
  std::size_t count = 0;
  void (*body)(void*, std::size_t) = nullptr;
  void* context = nullptr;
};

void pool_task(void* context, int, int) {
  PoolJobs& jobs = *static_cast<PoolJobs*>(context);
  for (std::size_t i = jobs.next.fetch_add(1); i < jobs.count; i = jobs.next.fetch_add(1)) jobs.body(jobs.context, i);
}

void pool_run(void* runner, std::size_t count, void (*body)(void*, std::size_t), void* context) {
  PoolJobs jobs;
  jobs.count = count;
  jobs.body = body;
  jobs.context = context;
  static_cast<WorkerPool*>(runner)->run(&pool_task, &jobs);
}

}  // namespace

ParallelFor pool_parallel_for(WorkerPool& pool) {
  ParallelFor pf;
  pf.run = &pool_run;
  pf.runner = &pool;
  return pf;
}

}  // namespace edgefuse
