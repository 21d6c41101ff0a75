#pragma once
// One line naming the machine a benchmark ran on, printed in every benchmark's header: the
// same build runs at different speeds on the CI's VM kinds (AVX-512 with 1 MiB of L2 per
// core, AVX2 with 512 KiB), so a figure without its machine cannot be compared.
#include <string>

namespace nephos::bench {

/// "CPU: <model name> (family F model M), N cores online, L2 <size> per core, L3 <size>;
/// built for <ISA>". Parts the system does not report are left out.
std::string describe_machine();

}  // namespace nephos::bench
