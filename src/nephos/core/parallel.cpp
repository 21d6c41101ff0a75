#include "nephos/core/parallel.hpp"

#include <omp.h>

#include "nephos/core/error.hpp"

namespace nephos {
void set_threads(int n) {
  if (n < 0)
    throw ValueError("thread count must be >= 0 (0 = all cores), got " + std::to_string(n), {.key = "--threads"});
  omp_set_num_threads(n == 0 ? omp_get_num_procs() : n);
}
int thread_count() { return omp_get_max_threads(); }
}  // namespace nephos
