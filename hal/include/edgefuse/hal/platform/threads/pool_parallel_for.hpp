// The localiser's parallel-for (localize/localizer.hpp ParallelFor) on a WorkerPool: jobs are
// handed out from an atomic counter; nothing is allocated per call.
#pragma once

#include "edgefuse/hal/platform/threads/worker_pool.hpp"
#include "edgefuse/localize/localizer.hpp"

namespace edgefuse {

//! The parallel-for on a started worker pool.
//! \param pool the workers (must outlive the localiser's use of the result)
ParallelFor pool_parallel_for(WorkerPool& pool);

}  // namespace edgefuse
