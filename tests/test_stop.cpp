// Stopping a fit and an experiment (FitOptions / ExperimentOptions::stop_requested: the Python
// module's Ctrl-C), and the CPUs the default thread counts use (usable_cpus).
#include <gtest/gtest.h>
#include <sched.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <thread>
#include <vector>

#include "hysteron/error.hpp"
#include "hysteron/experiment.hpp"
#include "hysteron/identify.hpp"
#include "hysteron/models.hpp"
#include "../src/identify/detail.hpp"
#include "temp_dir.hpp"

using namespace hysteron;

namespace {

// A hysteretic record: a gpi (Eq. 8's law) driven by triangles of decaying amplitude.
std::pair<std::vector<double>, std::vector<double>> gpi_record(int legs) {
  GpiParams g;
  g.envelope = Envelope::tanh(2.0, 0.4, -1.2, 1.5);
  g.q = 1.0;
  g.n = 10;
  g.rho = 0.5;
  g.tau = 1.5;
  g.alpha = 0.1;
  std::vector<double> x;
  for (int l = 0; l < legs; ++l) {
    const double a = 1.0 - 0.8 * l / legs;
    for (int k = 0; k < 400; ++k) x.push_back(a * std::sin(M_PI * k / 400.0));
  }
  return {x, simulate_record(ModelParams{g}, x)};
}

}  // namespace

TEST(UsableCpus, CountsTheAffinityMaskOfTheCallingThread) {
  const unsigned all = usable_cpus();
  EXPECT_GE(all, 1u);
  cpu_set_t mask;
  CPU_ZERO(&mask);
  ASSERT_EQ(sched_getaffinity(0, sizeof mask, &mask), 0);
  if (CPU_COUNT(&mask) < 2) GTEST_SKIP() << "one CPU allowed: nothing to restrict";
  EXPECT_LE(all, static_cast<unsigned>(CPU_COUNT(&mask)));  // never more than the mask
  int first = 0;
  while (!CPU_ISSET(first, &mask)) ++first;
  unsigned in_thread = 0;
  std::thread t([&] {  // taskset -c FIRST: only the thread's mask changes
    cpu_set_t one;
    CPU_ZERO(&one);
    CPU_SET(first, &one);
    if (sched_setaffinity(0, sizeof one, &one) == 0) in_thread = usable_cpus();
  });
  t.join();
  EXPECT_EQ(in_thread, 1u);  // hardware_concurrency() said CPU_COUNT of the machine here
  EXPECT_EQ(usable_cpus(), all);
}

// The cgroup CPU limit (detail::cgroup_cpu_limit) on cgroup trees built here, each with the
// quota worked out by hand: QUOTA / PERIOD rounded up, the least over the process's cgroup and its
// ancestors. Before 2026-12-01 only ROOT/cpu.max was read: the slice, the tighter quota deeper
// down and the v1 container gave 0 (no limit).
TEST(UsableCpus, TheCgroupLimitIsTheLeastQuotaUpTheHierarchy) {
  namespace fs = std::filesystem;
  const auto put = [](const fs::path& file, const std::string& text) {
    fs::create_directories(file.parent_path());
    std::ofstream(file) << text << "\n";
  };
  using detail::cgroup_cpu_limit;
  {  // no cgroup file at all, and a malformed one
    test::TempDir d;
    EXPECT_EQ(cgroup_cpu_limit(d.path().string(), "0::/\n"), 0u);
    put(d.path() / "cpu.max", "lots 100000");
    EXPECT_EQ(cgroup_cpu_limit(d.path().string(), "0::/\n"), 0u);
  }
  {  // cgroup v2 only (cgroup.controllers at the root): a container's own cgroup at the root, 0.5 CPU
    test::TempDir d;
    put(d.path() / "cgroup.controllers", "cpu memory");
    put(d.path() / "cpu.max", "50000 100000");
    EXPECT_EQ(cgroup_cpu_limit(d.path().string(), "0::/\n"), 1u);
    // a systemd slice with CPUQuota=150 % around the process's scope, which has none: 2 CPUs
    put(d.path() / "cpu.max", "max 100000");
    put(d.path() / "user.slice" / "cpu.max", "150000 100000");
    put(d.path() / "user.slice" / "app.scope" / "cpu.max", "max 100000");
    EXPECT_EQ(cgroup_cpu_limit(d.path().string(), "0::/user.slice/app.scope\n"), 2u);
    // a tighter quota deeper down wins: 3 CPUs inside a 4-CPU slice
    put(d.path() / "user.slice" / "cpu.max", "400000 100000");
    put(d.path() / "user.slice" / "app.scope" / "cpu.max", "300000 100000");
    EXPECT_EQ(cgroup_cpu_limit(d.path().string(), "0::/user.slice/app.scope\n"), 3u);
    // a path not below the mount (a container without its own cgroup namespace): the mount's root
    put(d.path() / "cpu.max", "250000 100000");
    EXPECT_EQ(cgroup_cpu_limit(d.path().string(), "0::/elsewhere/abc\n"), 3u);
  }
  {  // cgroup v1 (a hybrid host, as this VM): the cpu controller at ROOT/cpu, a container 2.5 CPUs
    test::TempDir d;
    put(d.path() / "cpu" / "cpu.cfs_quota_us", "-1");
    put(d.path() / "cpu" / "cpu.cfs_period_us", "100000");
    put(d.path() / "cpu" / "docker" / "c1" / "cpu.cfs_quota_us", "250000");
    put(d.path() / "cpu" / "docker" / "c1" / "cpu.cfs_period_us", "100000");
    fs::create_directories(d.path() / "unified");
    const std::string self = "4:memory:/docker/c1\n3:cpu,cpuacct:/docker/c1\n0::/docker/c1\n";
    EXPECT_EQ(cgroup_cpu_limit(d.path().string(), self), 3u);
    // unlimited everywhere (-1): none
    put(d.path() / "cpu" / "docker" / "c1" / "cpu.cfs_quota_us", "-1");
    EXPECT_EQ(cgroup_cpu_limit(d.path().string(), self), 0u);
  }
}

TEST(FitStop, AStopEndsTheFitWithStoppedAndNoReport) {
  const auto [x, y] = gpi_record(40);
  FitOptions o;
  o.model = FitModel::automatic;
  o.num_threads = 1;
  // uninterrupted: the hook asked, the report as without it
  std::atomic<long> asked{0};
  o.stop_requested = [&] {
    ++asked;
    return false;
  };
  const FitReport with_hook = fit(x, y, o);
  o.stop_requested = nullptr;
  const FitReport without = fit(x, y, o);
  ASSERT_TRUE(has_model(without.status)) << without.message;
  EXPECT_EQ(with_hook.status, without.status);
  EXPECT_EQ(with_hook.final_cost, without.final_cost);
  EXPECT_GT(asked.load(), 100);  // every LM iteration of every candidate asks
  // a stop after a tenth of the questions: Stopped, and hardly any work after it
  for (int threads : {1, 0}) {
    o.num_threads = threads;
    std::atomic<long> calls{0}, after{0};
    const long at = asked.load() / 10;
    o.stop_requested = [&] {
      const bool stop = ++calls > at;
      if (stop) ++after;
      return stop;
    };
    EXPECT_THROW((void)fit(x, y, o), Stopped) << "threads " << threads;
    EXPECT_LT(calls.load(), asked.load() / 2) << "threads " << threads;  // the rest of the fit did not run
  }
  // a stop is no Error: fit() does not turn it into a status
  o.stop_requested = [] { return true; };
  try {
    (void)fit(x, y, o);
    FAIL() << "a stopped fit returned a report";
  } catch (const Error&) {
    FAIL() << "a stop thrown as hysteron::Error";
  } catch (const Stopped& e) {
    EXPECT_STREQ(e.what(), "fit stopped (stop requested)");
  }
}

TEST(ExperimentStop, AStopEndsTheRunWithStopped) {
  ExperimentOptions o;
  o.name = "mpi-openloop";
  o.learning_periods = 0;
  o.model = FitModel::pi;
  // a stop after the identification run (the hook's 2nd question) and one inside the fits
  for (long at : {1L, 3L, 40L}) {
    std::atomic<long> calls{0};
    o.stop_requested = [&] { return ++calls > at; };
    const auto t0 = std::chrono::steady_clock::now();
    EXPECT_THROW((void)run_experiment(o), Stopped) << "stop at question " << at;
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    EXPECT_LT(s, 30.0);
  }
  // never asked to stop: a complete run
  o.stop_requested = [] { return false; };
  EXPECT_FALSE(run_experiment(o).runs.empty());
}
