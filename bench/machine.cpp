#include "machine.hpp"

#include <fmt/format.h>
#include <sys/resource.h>
#include <unistd.h>

#include <exception>
#include <fstream>
#include <string>

namespace nephos::bench {
namespace {

// The value of the first "key : value" line of /proc/cpuinfo with this key ("" if none).
std::string cpuinfo(const std::string& key) {
  std::ifstream in("/proc/cpuinfo");
  for (std::string line; std::getline(in, line);) {
    const auto colon = line.find(':');
    if (colon == std::string::npos) continue;
    std::string k = line.substr(0, colon);
    while (!k.empty() && (k.back() == ' ' || k.back() == '\t')) k.pop_back();
    if (k != key) continue;
    std::string v = line.substr(colon + 1);
    while (!v.empty() && v.front() == ' ') v.erase(v.begin());
    return v;
  }
  return "";
}

std::string bytes(long b) {
  if (b >= (1L << 20) && b % (1L << 20) == 0) return fmt::format("{} MiB", b >> 20);
  return fmt::format("{} KiB", b >> 10);
}

// Size in bytes of CPU 0's unified cache of this level, from sysfs as lscpu reads it (0 if not
// reported). sysfs rather than sysconf: under a hypervisor glibc's sysconf can report the
// host package's L3 (256 MiB on a VM whose L3 is 32 MiB).
long cache_bytes(int level) {
  for (int index = 0; index < 8; ++index) {
    const std::string dir = fmt::format("/sys/devices/system/cpu/cpu0/cache/index{}/", index);
    std::ifstream lv(dir + "level"), ty(dir + "type"), sz(dir + "size");
    int l = 0;
    std::string type, size;
    if (!(lv >> l) || !(ty >> type) || !(sz >> size)) continue;
    if (l != level || type != "Unified" || size.empty()) continue;
    long v = 0;
    try {
      v = std::stol(size);
    } catch (const std::exception&) {
      return 0;
    }
    const char unit = size.back();
    return unit == 'K' ? v << 10 : unit == 'M' ? v << 20 : v;
  }
  return 0;
}

}  // namespace

std::string describe_machine() {
  std::string s = "CPU: ";
  const std::string model = cpuinfo("model name");
  s += model.empty() ? "unknown" : model;
  const std::string family = cpuinfo("cpu family"), number = cpuinfo("model");
  if (!family.empty() && !number.empty()) s += fmt::format(" (family {} model {})", family, number);
  s += fmt::format(", {} cores online", sysconf(_SC_NPROCESSORS_ONLN));
  if (const long l2 = cache_bytes(2); l2 > 0) s += ", L2 " + bytes(l2) + " per core";
  if (const long l3 = cache_bytes(3); l3 > 0) s += ", L3 " + bytes(l3);
#if defined(__AVX512F__)
  s += "; built for AVX-512";
#elif defined(__AVX2__)
  s += "; built for AVX2";
#elif defined(__AVX__)
  s += "; built for AVX";
#else
  s += "; built for baseline x86-64";
#endif
  return s;
}

double peak_rss_mib() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0;  // ru_maxrss is in KiB on Linux
}

}  // namespace nephos::bench
