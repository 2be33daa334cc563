// How the core hands row-parallel work to the platform: the core calls run() with a job and a row
// count; the platform's threads (hal's PoolRowRunner) or the calling thread (a null runner) call
// rows(job, begin, end) over disjoint ranges. Every kernel that takes one gives the same result for
// any split, so threads never change what the core computes.
#pragma once

namespace edgefuse {

struct RowRunner {
  //! Calls rows(job, b, e) for disjoint [b, e) covering [0, count); returns when all are done.
  void (*run)(void* self, void (*rows)(void* job, int begin, int end), void* job, int count) = nullptr;
  void* self = nullptr;  //!< passed back as run's first argument (the pool)
};

}  // namespace edgefuse
