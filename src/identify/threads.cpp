// The CPUs a fit or a sweep may use (usable_cpus) and the stop hook of a fit (check_stop).
#include <sched.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <string>
#include <thread>

#include "detail.hpp"
#include "hysteron/error.hpp"

namespace hysteron {

namespace {

// The cgroup v2 CPU quota of this process, "QUOTA PERIOD" in /sys/fs/cgroup/cpu.max (a
// container's --cpus), rounded up; 0 where there is none ("max"), or it cannot be read.
unsigned cgroup_cpus() noexcept {
  try {
    std::ifstream f("/sys/fs/cgroup/cpu.max");
    std::string quota;
    double period = 0.0;
    if (!(f >> quota >> period) || quota == "max" || !(period > 0.0)) return 0;
    const double q = std::stod(quota);
    if (!(q > 0.0)) return 0;
    return static_cast<unsigned>(std::max(1.0, std::ceil(q / period)));
  } catch (...) {
    return 0;
  }
}

}  // namespace

unsigned usable_cpus() noexcept {
  unsigned n = 0;
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof set, &set) == 0) n = static_cast<unsigned>(CPU_COUNT(&set));
  if (n == 0) n = std::thread::hardware_concurrency();  // a mask of more than CPU_SETSIZE CPUs, or none known
  if (const unsigned q = cgroup_cpus(); q > 0) n = n > 0 ? std::min(n, q) : q;
  return std::max(1u, n);
}

void detail::check_stop(const FitOptions& o) {
  if (o.stop_requested && o.stop_requested()) throw Stopped("fit stopped (stop requested)");
}

}  // namespace hysteron
