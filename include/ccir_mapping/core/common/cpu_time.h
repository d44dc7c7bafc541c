// CPU time of the calling thread, for the per-stage CPU budget each nodelet reports (a stage
// that waits for a lock or the disk costs no CPU, so wall time would mislead on a busy machine).
#pragma once

#include <ctime>

namespace ccir_mapping::core {

/// Seconds of CPU the calling thread has used since it started.
inline double threadCpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

}  // namespace ccir_mapping::core
