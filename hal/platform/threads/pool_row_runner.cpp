#include "edgefuse/hal/platform/threads/pool_row_runner.hpp"

#include <atomic>

namespace edgefuse {

namespace {

struct RowJob {
  void (*rows)(void*, int, int);
  void* job;
  int count;
  int chunk;
  std::atomic<int> next{0};
};

void row_worker(void* p, int, int) {
  RowJob* j = static_cast<RowJob*>(p);
  for (;;) {
    const int b = j->next.fetch_add(j->chunk);
    if (b >= j->count) return;
    j->rows(j->job, b, b + j->chunk < j->count ? b + j->chunk : j->count);
  }
}

}  // namespace

PoolRowRunner::PoolRowRunner(WorkerPool& pool, int chunk_rows)
    : pool_(pool), chunk_rows_(chunk_rows > 0 ? chunk_rows : 1) {
  runner_.run = &PoolRowRunner::run;
  runner_.self = this;
}

void PoolRowRunner::run(void* self, void (*rows)(void*, int, int), void* job, int count) {
  PoolRowRunner* me = static_cast<PoolRowRunner*>(self);
  RowJob j;  // on the stack: run() returns when every worker is done with it
  j.rows = rows;
  j.job = job;
  j.count = count;
  j.chunk = me->chunk_rows_;
  me->pool_.run(&row_worker, &j);
}

}  // namespace edgefuse
