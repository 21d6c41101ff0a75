#pragma once
// The machine and process a benchmark ran on: one line naming the machine, printed in every
// benchmark's header (the same build runs at different speeds on the CI's VM kinds, AVX-512
// with 1 MiB of L2 per core and AVX2 with 512 KiB, so a figure without its machine cannot be
// compared), and the process's peak memory.
#include <string>

namespace nephos::bench {

/// "CPU: <model name> (family F model M), N cores online, L2 <size> per core, L3 <size>;
/// built for <ISA>". Parts the system does not report are left out.
std::string describe_machine();

/// Peak resident memory of this process so far [MiB] (getrusage's ru_maxrss).
double peak_rss_mib();

}  // namespace nephos::bench
