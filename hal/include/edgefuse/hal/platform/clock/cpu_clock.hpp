// CPU time of the calling thread or of the whole process (what a job cost, whatever else the
// machine ran meanwhile).
#pragma once

#include <time.h>

namespace edgefuse::hal {

inline double thread_cpu_ms() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return double(ts.tv_sec) * 1e3 + double(ts.tv_nsec) * 1e-6;
}

//! CPU time of all the process's threads so far, in ms.
inline double process_cpu_ms() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) * 1e3 + double(ts.tv_nsec) * 1e-6;
}

}  // namespace edgefuse::hal
