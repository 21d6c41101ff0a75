#pragma once
// Thread-count control for OpenMP regions. Results never depend on the count (see hash.hpp).
namespace nephos {
/// Sets the number of OpenMP threads used by nephos; n <= 0 means "all cores".
void set_threads(int n);
/// The number of threads an OpenMP region will use.
int thread_count();
}  // namespace nephos
