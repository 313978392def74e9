// The CPUs a fit or a sweep may use (usable_cpus) and the stop hook of a fit (check_stop).
#include <sched.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <sstream>
#include <string>
#include <thread>

#include "detail.hpp"
#include "hysteron/error.hpp"

namespace hysteron {

namespace {

// "QUOTA PERIOD" (cgroup v2 cpu.max) or QUOTA and PERIOD from two files (v1
// cpu.cfs_quota_us, cpu.cfs_period_us) as CPUs, rounded up; 0 where unlimited ("max", -1) or
// unreadable.
unsigned quota_cpus(const std::string& quota, double period) {
  if (quota.empty() || quota == "max" || !(period > 0.0)) return 0;
  double q = 0.0;
  const auto [end, ec] = std::from_chars(quota.data(), quota.data() + quota.size(), q);
  if (ec != std::errc() || end != quota.data() + quota.size() || !(q > 0.0) || !std::isfinite(q)) return 0;
  return static_cast<unsigned>(std::max(1.0, std::min(std::ceil(q / period), 65536.0)));
}

unsigned v2_level(const std::filesystem::path& dir) {
  std::ifstream f(dir / "cpu.max");
  std::string quota;
  double period = 0.0;
  if (!(f >> quota >> period)) return 0;
  return quota_cpus(quota, period);
}

unsigned v1_level(const std::filesystem::path& dir) {
  std::ifstream fq(dir / "cpu.cfs_quota_us"), fp(dir / "cpu.cfs_period_us");
  std::string quota;
  double period = 0.0;
  if (!(fq >> quota) || !(fp >> period)) return 0;
  return quota_cpus(quota, period);
}

// The least limit of `level` over `mount` / `path` and its ancestors up to `mount` (a
// slice's quota binds the cgroups inside it); `mount` alone where `path` is not below it
// (a container that sees only its own cgroup at the mount's root).
unsigned least_up_to(const std::filesystem::path& mount, std::string_view path,
                     unsigned (*level)(const std::filesystem::path&)) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::is_directory(mount, ec)) return 0;
  fs::path rel = fs::path(std::string(path)).relative_path().lexically_normal();
  if (rel.empty() || *rel.begin() == ".." || !fs::is_directory(mount / rel, ec)) rel.clear();
  unsigned least = 0;
  for (fs::path p = rel;; p = p.parent_path()) {
    if (const unsigned n = level(p.empty() ? mount : mount / p); n > 0) least = least == 0 ? n : std::min(least, n);
    if (p.empty() || p == p.parent_path()) break;
  }
  return least;
}

}  // namespace

unsigned detail::cgroup_cpu_limit(const std::string& cgroup_root, const std::string& self_cgroup) noexcept {
  try {
    namespace fs = std::filesystem;
    const fs::path root(cgroup_root);
    unsigned least = 0;
    const auto take = [&](unsigned n) {
      if (n > 0) least = least == 0 ? n : std::min(least, n);
    };
    std::istringstream lines(self_cgroup);
    for (std::string line; std::getline(lines, line);) {
      // "ID:CONTROLLERS:PATH"; the v2 hierarchy is "0::PATH"
      const auto c1 = line.find(':'), c2 = c1 == std::string::npos ? c1 : line.find(':', c1 + 1);
      if (c2 == std::string::npos) continue;
      const std::string controllers = line.substr(c1 + 1, c2 - c1 - 1), path = line.substr(c2 + 1);
      if (line.compare(0, c1, "0") == 0 && controllers.empty()) {
        // the unified hierarchy: mounted at the root (v2 only) or at root/unified (hybrid)
        std::error_code ec;
        take(least_up_to(fs::exists(root / "cgroup.controllers", ec) ? root : root / "unified", path, v2_level));
        continue;
      }
      std::istringstream names(controllers);
      for (std::string name; std::getline(names, name, ',');)
        if (name == "cpu") {  // cgroup v1's CPU controller: root/cpu (often a link to cpu,cpuacct)
          std::error_code ec;
          take(least_up_to(fs::exists(root / "cpu", ec) ? root / "cpu" : root / controllers, path, v1_level));
          break;
        }
    }
    if (least == 0) take(v2_level(root));  // no /proc/self/cgroup: the top-level v2 file, as before
    return least;
  } catch (...) {
    return 0;
  }
}

unsigned usable_cpus() noexcept {
  unsigned n = 0;
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof set, &set) == 0) n = static_cast<unsigned>(CPU_COUNT(&set));
  if (n == 0) n = std::thread::hardware_concurrency();  // a mask of more than CPU_SETSIZE CPUs, or none known
  std::string self;
  try {
    std::ifstream f("/proc/self/cgroup");
    self.assign(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
  } catch (...) {
    self.clear();
  }
  if (const unsigned q = detail::cgroup_cpu_limit("/sys/fs/cgroup", self); q > 0) n = n > 0 ? std::min(n, q) : q;
  return std::max(1u, n);
}

void detail::check_stop(const FitOptions& o) {
  if (o.stop_requested && o.stop_requested()) throw Stopped("fit stopped (stop requested)");
}

}  // namespace hysteron
