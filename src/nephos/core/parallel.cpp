#include "nephos/core/parallel.hpp"

#include <omp.h>

#include "nephos/core/error.hpp"

namespace nephos {
void set_threads(int n) {
  // Beyond a few threads per core OpenMP only oversubscribes; a million would exhaust the
  // process's memory for stacks before any work.
  constexpr int max_threads = 1024;
  if (n < 0 || n > max_threads)
    throw ValueError("thread count must be 0..1024 (0 = all cores), got " + std::to_string(n), {.key = "threads"});
  omp_set_num_threads(n == 0 ? omp_get_num_procs() : n);
}
int thread_count() { return omp_get_max_threads(); }
}  // namespace nephos
