// The core's RowRunner (ICP row sums, pair calibration) over a WorkerPool: rows are handed out in
// chunks from an atomic counter, so uneven rows balance across cores. The core reduces the per-row
// sums in row order, so the split never changes the result. Nothing is allocated per run.
#pragma once

#include "edgefuse/tracking/icp.hpp"
#include "edgefuse/hal/platform/threads/worker_pool.hpp"

namespace edgefuse {

class PoolRowRunner {
 public:
  //! \param pool a started worker pool (kept by reference)  \param chunk_rows rows per hand-out
  explicit PoolRowRunner(WorkerPool& pool, int chunk_rows = 4);
  PoolRowRunner(const PoolRowRunner&) = delete;
  PoolRowRunner& operator=(const PoolRowRunner&) = delete;

  //! The RowRunner to give the core; valid while this object lives.
  const RowRunner* runner() const { return &runner_; }

 private:
  static void run(void* self, void (*rows)(void* job, int begin, int end), void* job, int count);

  WorkerPool& pool_;
  int chunk_rows_;
  RowRunner runner_;
};

}  // namespace edgefuse
