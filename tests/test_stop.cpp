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
