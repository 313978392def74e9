// Worst-case latency of the C ABI's real-time calls (issue 12, item 5).
//
//   build/hysteron-c-latency [--calls N] [--model M.json] [--warmup W]
//
// Times every call with clock_gettime(CLOCK_MONOTONIC) (a vDSO read, ~20 ns, measured
// and printed as "timer overhead": it is included in every figure) for N calls
// (default 10^7) of
//   hysteron_inverse_step                     the exact inverse alone
//   hysteron_ff_pid_step                      inverse feedforward + PID (GPI paper, Fig. 10)
//   hysteron_open_loop_step                   the same + the pressure loop (k_p = 0.5)
//   hysteron_cascade_step                     the same outer loop + P pressure loop + PWM
//   hysteron_ilc_correction + hysteron_ilc_step   iterative learning on top of it (period 20 000,
//                                             Q-filter half-width 2006 and lead 56, the demo's
//                                             gpi-pid design, unsupervised: an update every
//                                             sample; docs/control.md section 3)
// in a closed loop with the forward model as the plant (the plant's step is not timed),
// after W warm-up calls (default 10^5). The reference is a periodic trajectory with
// minor loops (precomputed). Prints median, p99, p99.9, p99.99 and max in ns from an
// exact 1-ns histogram, and the number of heap allocations during the timed loops,
// counted by replacing malloc/calloc/realloc/aligned allocation and operator new in this
// program (the library's allocations go through them too; checked by a call that does
// allocate). Exit status 1 if a timed call failed or allocated.
//
// Without --model it uses a GPI with 10 operators (tanh envelope), input limits
// [-0.9, 0.9]. Figures depend on the machine and on its load: no test asserts them.
#include <sys/mman.h>
#include <sys/resource.h>
#include <time.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <new>
#include <string>
#include <vector>

#include "hysteron/hysteron.h"

// ---- allocation counting --------------------------------------------------------
namespace {
std::atomic<std::size_t> g_allocations{0};
inline void count() noexcept { g_allocations.fetch_add(1, std::memory_order_relaxed); }
}  // namespace

extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void* __libc_memalign(std::size_t, std::size_t);
void __libc_free(void*);

void* malloc(std::size_t n) noexcept {
  count();
  return __libc_malloc(n);
}
void* calloc(std::size_t a, std::size_t b) noexcept {
  count();
  return __libc_calloc(a, b);
}
void* realloc(void* p, std::size_t n) noexcept {
  count();
  return __libc_realloc(p, n);
}
void free(void* p) noexcept { __libc_free(p); }
void* memalign(std::size_t a, std::size_t n) noexcept {
  count();
  return __libc_memalign(a, n);
}
void* aligned_alloc(std::size_t a, std::size_t n) noexcept {
  count();
  return __libc_memalign(a, n);
}
int posix_memalign(void** p, std::size_t a, std::size_t n) noexcept {
  count();
  *p = __libc_memalign(a, n);
  return *p ? 0 : ENOMEM;
}
}

namespace {
void* counted_new(std::size_t n, std::size_t align) {
  count();
  void* p = align <= alignof(std::max_align_t) ? __libc_malloc(n ? n : 1) : __libc_memalign(align, n ? n : 1);
  if (!p) throw std::bad_alloc();
  return p;
}
}  // namespace

void* operator new(std::size_t n) { return counted_new(n, alignof(std::max_align_t)); }
void* operator new[](std::size_t n) { return counted_new(n, alignof(std::max_align_t)); }
void* operator new(std::size_t n, std::align_val_t a) { return counted_new(n, static_cast<std::size_t>(a)); }
void* operator new[](std::size_t n, std::align_val_t a) { return counted_new(n, static_cast<std::size_t>(a)); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  try { return counted_new(n, alignof(std::max_align_t)); } catch (...) { return nullptr; }
}
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept {
  try { return counted_new(n, alignof(std::max_align_t)); } catch (...) { return nullptr; }
}
void operator delete(void* p) noexcept { __libc_free(p); }
void operator delete[](void* p) noexcept { __libc_free(p); }
void operator delete(void* p, std::size_t) noexcept { __libc_free(p); }
void operator delete[](void* p, std::size_t) noexcept { __libc_free(p); }
void operator delete(void* p, std::align_val_t) noexcept { __libc_free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { __libc_free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { __libc_free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { __libc_free(p); }

// ---- timing ---------------------------------------------------------------------------
namespace {

// Involuntary context switches of this thread so far (preemptions by other processes).
long preemptions() noexcept {
  rusage u;
  return getrusage(RUSAGE_THREAD, &u) == 0 ? u.ru_nivcsw : -1;
}

inline std::int64_t now_ns() noexcept {
  timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return static_cast<std::int64_t>(t.tv_sec) * 1000000000 + t.tv_nsec;
}

// Exact latency distribution at 1 ns resolution up to 1 ms, plus the maximum.
struct Histogram {
  std::vector<std::uint64_t> bins = std::vector<std::uint64_t>(1 << 20, 0);
  std::uint64_t count = 0, overflow = 0;
  std::int64_t max = 0;
  double sum = 0;
  void add(std::int64_t ns) noexcept {
    if (ns < 0) ns = 0;
    if (ns < static_cast<std::int64_t>(bins.size())) ++bins[static_cast<std::size_t>(ns)]; else ++overflow;
    max = std::max(max, ns);
    sum += static_cast<double>(ns);
    ++count;
  }
  std::int64_t percentile(double q) const {
    const auto target = static_cast<std::uint64_t>(std::ceil(q * static_cast<double>(count)));
    std::uint64_t seen = 0;
    for (std::size_t i = 0; i < bins.size(); ++i) {
      seen += bins[i];
      if (seen >= target && target > 0) return static_cast<std::int64_t>(i);
    }
    return max;
  }
};

const char* k_default_model = R"({"schema": 1, "model": "gpi", "envelope": "tanh", "c": [1.2, 0.8, 0.1, 0.05],
  "q": 0.5, "n": 10, "rho": 0.3, "tau": 1.5, "alpha": 0.05, "input_limits": [-0.9, 0.9],
  "units": {"input": "MPa", "output": "mm"}})";

[[noreturn]] void die(const char* what, hysteron_status st) {
  std::fprintf(stderr, "hysteron-c-latency: %s: %s: %s\n", what, hysteron_status_name(st), hysteron_last_error());
  std::exit(2);
}

void print_row(const char* name, const Histogram& h, std::size_t allocations, std::size_t failures) {
  std::printf("%-38s %8lld %8lld %8lld %8lld %8lld %9.1f %12zu %9zu\n", name,
              static_cast<long long>(h.percentile(0.5)), static_cast<long long>(h.percentile(0.99)),
              static_cast<long long>(h.percentile(0.999)), static_cast<long long>(h.percentile(0.9999)),
              static_cast<long long>(h.max), h.sum / static_cast<double>(h.count), allocations, failures);
}

}  // namespace

int main(int argc, char** argv) {
  std::size_t calls = 10000000, warmup = 100000;
  std::string model_path;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--calls" && i + 1 < argc) calls = std::strtoull(argv[++i], nullptr, 10);
    else if (a == "--warmup" && i + 1 < argc) warmup = std::strtoull(argv[++i], nullptr, 10);
    else if (a == "--model" && i + 1 < argc) model_path = argv[++i];
    else {
      std::fprintf(stderr, "usage: %s [--calls N] [--warmup W] [--model M.json]\n", argv[0]);
      return 2;
    }
  }
  if (calls == 0) calls = 1;

  hysteron_params* params = nullptr;
  hysteron_status st = model_path.empty() ? hysteron_params_from_json(k_default_model, &params)
                                          : hysteron_params_from_file(model_path.c_str(), &params);
  if (st != HYSTERON_OK) die("loading the model", st);
  const char* kind = nullptr;
  std::size_t n_ops = 0;
  hysteron_params_kind(params, &kind);
  hysteron_params_num_operators(params, &n_ops);
  hysteron_inverse* inverse = nullptr;
  if ((st = hysteron_inverse_create(params, -HUGE_VAL, HUGE_VAL, &inverse)) != HYSTERON_OK) die("inverse", st);
  double lo = 0, hi = 0;
  hysteron_inverse_limits(inverse, &lo, &hi);
  if (!std::isfinite(lo) || !std::isfinite(hi)) {
    lo = std::isfinite(lo) ? lo : -1.0;
    hi = std::isfinite(hi) ? hi : 1.0;
  }
  hysteron_model* plant = nullptr;
  if ((st = hysteron_model_create(params, &plant)) != HYSTERON_OK) die("model", st);
  hysteron_ff_pid_params cp;
  hysteron_ff_pid_default_params(&cp);
  cp.pressure_min = lo;
  cp.pressure_max = hi;
  cp.kp = 5.0;
  cp.ki = 1.0;
  cp.kd = 0.01;
  cp.derivative_filter = 0.005;
  hysteron_ff_pid* ctl = nullptr;
  if ((st = hysteron_ff_pid_create(params, &cp, &ctl)) != HYSTERON_OK) die("controller", st);

  // Reference: the model's output (metres, model in mm) for an input with minor loops
  // that also reaches beyond the limits now and then (saturation paths), period 20 000.
  const std::size_t period = 20000;
  std::vector<double> x_ref(period), y_ref(period);
  const double mid = 0.5 * (lo + hi), half = 0.5 * (hi - lo);
  for (std::size_t k = 0; k < period; ++k) {
    const double t = static_cast<double>(k) / static_cast<double>(period);
    x_ref[k] = mid + half * (0.9 * std::sin(2 * M_PI * t) * (0.6 + 0.4 * std::cos(6 * M_PI * t)) +
                             0.25 * std::sin(2 * M_PI * 37 * t));
  }
  hysteron_model_simulate(plant, x_ref.data(), period, y_ref.data(), period);
  for (double& y : y_ref) y /= 1000.0;
  hysteron_model_reset(plant);

  Histogram timer, inv_h, ctl_h, ilc_h;
  hysteron_ilc_params ip;
  hysteron_ilc_default_params(&ip);
  ip.period = period;
  ip.gain = 0.5;
  ip.lead = 56;
  ip.half_width = 2006;
  // unsupervised and never held, so that every sample computes its update (the worst case; the
  // learning variant's supervisor may hold the best correction, after which a step costs less)
  ip.max_correction = 0.01;  // [m]: bounded whatever this toy loop does with it
  hysteron_ilc* ilc = nullptr;
  if ((st = hysteron_ilc_create(&ip, &ilc)) != HYSTERON_OK) die("learning", st);
  const int locked = mlockall(MCL_CURRENT);
  std::printf("hysteron C ABI %s: worst-case latency, %zu timed calls each after %zu warm-up calls\n",
              hysteron_version_string(), calls, warmup);
  std::printf("model: %s, %s with %zu operators; input limits [%g, %g]; memory %s\n",
              model_path.empty() ? "built-in" : model_path.c_str(), kind, n_ops, lo, hi,
              locked == 0 ? "locked (mlockall)" : "not locked (mlockall refused)");

  // Self-check of the allocation counter: this call does allocate.
  {
    const std::size_t before = g_allocations.load();
    std::vector<double> s(n_ops + 1);
    double u = 0;
    hysteron_inverse_get_state(inverse, s.data(), n_ops, &u);
    if (g_allocations.load() - before < 2) {
      std::fprintf(stderr, "hysteron-c-latency: the allocation counter does not see the library's allocations\n");
      return 2;
    }
  }

  // 1. timer overhead
  for (std::size_t k = 0; k < warmup; ++k) { volatile std::int64_t t = now_ns(); (void)t; }
  for (std::size_t k = 0; k < calls; ++k) {
    const std::int64_t t0 = now_ns();
    const std::int64_t t1 = now_ns();
    timer.add(t1 - t0);
  }

  // 2. inverse alone
  std::size_t inv_fail = 0;
  double x = 0, sink = 0;
  int sat = 0;
  for (std::size_t k = 0; k < warmup; ++k) hysteron_inverse_step(inverse, y_ref[k % period] * 1000.0, &x, &sat);
  hysteron_inverse_reset(inverse);
  std::size_t a0 = g_allocations.load();
  long c0 = preemptions();
  for (std::size_t k = 0; k < calls; ++k) {
    const double y = y_ref[k % period] * 1000.0;
    const std::int64_t t0 = now_ns();
    const hysteron_status s = hysteron_inverse_step(inverse, y, &x, &sat);
    const std::int64_t t1 = now_ns();
    inv_h.add(t1 - t0);
    inv_fail += s != HYSTERON_OK;
    sink += x;
  }
  const std::size_t inv_alloc = g_allocations.load() - a0;
  const long inv_preempt = preemptions() - c0;

  // 3. feedforward + PID in a closed loop with the model as plant
  std::size_t ctl_fail = 0;
  double p = 0, measured = 0, y = 0;
  for (std::size_t k = 0; k < warmup; ++k) {
    hysteron_ff_pid_step(ctl, y_ref[k % period], y_ref[k % period], measured, &p);
    hysteron_model_step(plant, p, &y);
    measured = y / 1000.0;
  }
  hysteron_ff_pid_reset(ctl);
  hysteron_model_reset(plant);
  measured = 0;
  a0 = g_allocations.load();
  c0 = preemptions();
  for (std::size_t k = 0; k < calls; ++k) {
    const double r = y_ref[k % period];
    const std::int64_t t0 = now_ns();
    const hysteron_status s = hysteron_ff_pid_step(ctl, r, r, measured, &p);
    const std::int64_t t1 = now_ns();
    ctl_h.add(t1 - t0);
    ctl_fail += s != HYSTERON_OK;
    hysteron_model_step(plant, p, &y);
    measured = y / 1000.0;
    sink += p;
  }
  const std::size_t ctl_alloc = g_allocations.load() - a0;
  const long ctl_preempt = preemptions() - c0;

  // 4./5. the open loop with its pressure loop and the cascade on switching valves, in the same
  // closed loop; the actuator (untimed) a first-order lag of the command (open loop) or the
  // duty integrated into the pressure (cascade), the model as the muscle
  hysteron_open_loop_params op;
  hysteron_open_loop_default_params(&op);
  op.loop = cp;
  hysteron_open_loop* ol = nullptr;
  if ((st = hysteron_open_loop_create(params, &op, &ol)) != HYSTERON_OK) die("open loop", st);
  hysteron_cascade_params cc;
  hysteron_cascade_default_params(&cc);
  cc.outer = cp;
  hysteron_cascade* cas = nullptr;
  if ((st = hysteron_cascade_create(params, &cc, &cas)) != HYSTERON_OK) die("cascade", st);
  struct Row {
    Histogram h;
    std::size_t fail = 0, alloc = 0;
    long preempt = 0;
  } rows[2];  // open loop, cascade
  for (int which = 0; which < 2; ++which) {
    Row& row = rows[which];
    double pressure = lo;
    hysteron_model_reset(plant);
    measured = 0;
    a0 = g_allocations.load();
    c0 = preemptions();
    for (std::size_t k = 0; k < warmup + calls; ++k) {
      const double r = y_ref[k % period];
      double u = 0, pd = 0;
      const std::int64_t t0 = now_ns();
      const hysteron_status s = which == 0 ? hysteron_open_loop_step(ol, r, r, measured, pressure, &u)
                                           : hysteron_cascade_step(cas, r, r, measured, pressure, &u, &pd);
      const std::int64_t t1 = now_ns();
      if (k >= warmup) {
        row.h.add(t1 - t0);
        row.fail += s != HYSTERON_OK;
      }
      pressure = which == 0 ? pressure + 0.2 * (u - pressure) : std::clamp(pressure + 0.05 * (hi - lo) * u, lo, hi);
      hysteron_model_step(plant, pressure, &y);
      measured = y / 1000.0;
      sink += u;
    }
    row.alloc = g_allocations.load() - a0;
    row.preempt = preemptions() - c0;
  }
  const Row& olr = rows[0];
  const Row& casr = rows[1];

  // 6. iterative learning on top of the ff+pid loop (only its two calls timed)
  std::size_t ilc_fail = 0;
  hysteron_ff_pid_reset(ctl);
  hysteron_model_reset(plant);
  measured = 0;
  a0 = g_allocations.load();
  c0 = preemptions();
  for (std::size_t k = 0; k < warmup + calls; ++k) {
    const double r = y_ref[k % period];
    double c = 0;
    const std::int64_t t0 = now_ns();
    hysteron_status s = hysteron_ilc_correction(ilc, 0, &c);
    const std::int64_t t1 = now_ns();
    hysteron_ff_pid_step(ctl, r + c, r + c, measured, &p);
    hysteron_model_step(plant, p, &y);
    measured = y / 1000.0;
    const std::int64_t t2 = now_ns();
    if (s == HYSTERON_OK) s = hysteron_ilc_step(ilc, r - measured);
    const std::int64_t t3 = now_ns();
    if (k >= warmup) {
      ilc_h.add((t1 - t0) + (t3 - t2));
      ilc_fail += s != HYSTERON_OK;
    }
    sink += c;
  }
  const std::size_t ilc_alloc = g_allocations.load() - a0;
  const long ilc_preempt = preemptions() - c0;

  std::printf("%-38s %8s %8s %8s %8s %8s %9s %12s %9s\n", "latency per call [ns]", "median", "p99", "p99.9", "p99.99",
              "max", "mean", "allocations", "failures");
  print_row("timer overhead (two clock_gettime)", timer, 0, 0);
  print_row("hysteron_inverse_step", inv_h, inv_alloc, inv_fail);
  print_row("hysteron_ff_pid_step (inverse + PID)", ctl_h, ctl_alloc, ctl_fail);
  print_row("hysteron_open_loop_step", olr.h, olr.alloc, olr.fail);
  print_row("hysteron_cascade_step", casr.h, casr.alloc, casr.fail);
  print_row("hysteron_ilc_correction + _step", ilc_h, ilc_alloc, ilc_fail);
  std::printf("calls above 1 ms: inverse %llu, ff+pid %llu, open loop %llu, cascade %llu, ilc %llu; involuntary context "
              "switches during the timed loops (preemptions, each can make one call's max): inverse %ld, ff+pid %ld, "
              "open loop %ld, cascade %ld, ilc %ld; (checksum %.6g)\n",
              static_cast<unsigned long long>(inv_h.overflow), static_cast<unsigned long long>(ctl_h.overflow),
              static_cast<unsigned long long>(olr.h.overflow), static_cast<unsigned long long>(casr.h.overflow),
              static_cast<unsigned long long>(ilc_h.overflow), inv_preempt, ctl_preempt, olr.preempt, casr.preempt,
              ilc_preempt, sink);
  hysteron_ilc_free(ilc);
  hysteron_open_loop_free(ol);
  hysteron_cascade_free(cas);

  hysteron_ff_pid_free(ctl);
  hysteron_model_free(plant);
  hysteron_inverse_free(inverse);
  hysteron_params_free(params);
  return (inv_alloc || ctl_alloc || olr.alloc || casr.alloc || ilc_alloc || inv_fail || ctl_fail || olr.fail || casr.fail ||
          ilc_fail)
             ? 1
             : 0;
}
