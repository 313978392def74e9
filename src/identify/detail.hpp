#pragma once
// Internal helpers shared by the identification sources (not installed).
#include <Eigen/Core>

#include <array>
#include <chrono>
#include <cmath>
#include <random>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "hysteron/identify.hpp"

namespace hysteron::detail {

// The CPU limit of this process's cgroups [CPUs, rounded up], 0 where there is none:
// `self_cgroup` is /proc/self/cgroup's text ("ID:CONTROLLERS:PATH" lines), `cgroup_root` where
// the hierarchies are mounted (/sys/fs/cgroup). The least quota over the process's cgroup and its
// ancestors, in cgroup v2 (cpu.max; the unified hierarchy at the root, or at root/unified on a
// hybrid host) and in v1's CPU controller (cpu.cfs_quota_us / cpu.cfs_period_us under root/cpu):
// a systemd slice's CPUQuota binds the cgroups inside it, a v1 container's --cpus is at its
// mount's root. A path not below the mount (a container that sees only its own cgroup there)
// reads the mount's root. Without a readable line, root/cpu.max as before (2026-12-01).
unsigned cgroup_cpu_limit(const std::string& cgroup_root, const std::string& self_cgroup) noexcept;

// A uniform draw in [a, b) from two 32-bit words of `rng` (std::mt19937, whose sequence the
// standard fixes), computed as libstdc++'s uniform_real_distribution<double> computes it
// (generate_canonical<double, 53>: (w1 + 2^32 w2) / 2^64, below 1), written out so that a fit
// with a seed (FitOptions::seed: the starts' jitter) gives the same model with any standard
// library: libc++ and MSVC draw other values from the same engine.
inline double uniform_draw(std::mt19937& rng, double a, double b) {
  const double w1 = static_cast<double>(rng());
  const double w2 = static_cast<double>(rng());
  double u = (w1 + w2 * 4294967296.0) / 18446744073709551616.0;  // 2^32, 2^64
  if (u >= 1.0) u = std::nextafter(1.0, 0.0);
  return u * (b - a) + a;
}

// Throws hysteron::Error if x and y differ in length, are empty or hold a non-finite value.
void check_record(std::span<const double> x, std::span<const double> y, std::string_view what);
// Throws if the range is empty or reaches past n.
IndexRange check_range(IndexRange range, std::size_t n, std::string_view what);

// Regressor matrix of a structure with fixed thresholds and envelopes: row k is
// [u_m(k), y_1(k), ..., y_n(k)] after sample k (rows [0, rows) of the record are
// simulated, only rows in `range` are stored).
Eigen::MatrixXd regressors(const Structure<double>& s, std::span<const double> x, IndexRange range,
                           InitialState initial);

// Nonnegative least squares min ||A t - b||, t >= 0 (Lawson-Hanson active set on
// the column-scaled normal equations, accumulated 4096 rows of A at a time: no copy
// of A, scratch of one block of rows).
Eigen::VectorXd nnls(const Eigen::MatrixXd& A, const Eigen::VectorXd& b);

// Bounded least squares min ||A t + c - b||, t >= lo. With `offset` != nullptr the
// offset c is free: it is eliminated exactly by centring the columns and the target
// (each block of rows is centred before it enters the normal equations: no
// A^T A - m mu mu^T cancellation), and *offset receives its least-squares value (the
// mean residual); otherwise c = 0. *sse (if given) receives the residual sum of
// squares (a second pass over A). Memory: n x n plus one block of rows, not m x n.
Eigen::VectorXd bounded_ls(const Eigen::MatrixXd& A, const Eigen::VectorXd& b, const Eigen::VectorXd& lo,
                           double* offset, double* sse = nullptr);

// The model `model` with canonical thresholds s.r and the weights q, p.
ModelParams with_weights(const ModelParams& model, const Structure<double>& s, double q,
                         const std::vector<double>& p);

double span_of(std::span<const double> v);

// An input reversal: the input moves back from its last extremum by more than this fraction of its training span
// (noise and small wiggles are not reversals).
inline constexpr double kReversalFraction = 0.1;
// The reversals of x over [from, to) (by more than kReversalFraction of span): the sample of each turning extremum
// and +1 for a maximum, -1 for a minimum. (sensor_faults.cpp)
std::vector<std::pair<std::size_t, int>> reversals(std::span<const double> x, std::size_t from, std::size_t to,
                                                   double span);

// The grid a column was recorded on (an ADC's or a printout's resolution): step = the least spacing of its
// distinct values (values within 1e-9 of their magnitude are one: rounding after an offset or a scale; levels
// left unused are no matter), refined to span / round(span / spacing), when every value lies within a tenth of a
// step of min + k step and there are at least 4 samples per level; {0, 0} otherwise (a column off any grid, or
// too short to tell). levels = span / step + 1.
// (sensor_faults.cpp)
struct Grid {
  double step = 0.0;
  std::size_t levels = 0;
};
Grid grid_of(std::span<const double> v);

// A sensor that clips: runs (at least 3 samples) of column a sitting exactly at its least ([0]) or largest ([1])
// value over `range` during which column b moves (its range over the run) by more than the largest of 3x
// the most b moves during any run of a at another value (a held command's creep or settling, a coarse sensor's
// step), 8 noise widths of b (detect_clipping's sigma) and 10 % of b's span (a creep where a holds only at its
// ends), and in which b turns back: its extreme inside the run lies beyond both of the run's ends by more than 8
// noise widths and 5 % of its range there (an output that settles while the input rests at 0 is monotone). A
// clipped sensor's true value went on beyond its range and came back while its reading stayed. (sensor_faults.cpp)
struct Pinned {
  double value = 0.0;                            // a's least or largest value
  std::size_t samples = 0, first = 0, last = 0;  // samples in the flagged runs; the first one is [first, last)
  double moved = 0.0;                            // the most b moves in them
  double moves = 0.0;                            // the most b moves during any run of a at another value
  std::size_t holds = 0;  // runs of a at another value of 2 samples or more (none: `moves` is 0, no measurement)
  std::vector<IndexRange> flagged;  // every flagged run, in order
};
std::array<Pinned, 2> pinned_runs(std::span<const double> a, std::span<const double> b, IndexRange range);

// A stuck output sensor: runs of y at one value inside its range by more than 10 % of its span (a dead zone or a
// stop rests at about its least or largest value; pinned_runs names clips there) at least 10x as long as the other
// runs of one y value there (leaving out the longest 1 % of them, so that a second stuck stretch does not hide the
// first) and 10 samples or more, during which x moves one way (no reversal by 10 % of its span inside the run) by
// more than 10 % of its span, and y moved (by more than 8 noise widths, detect_clipping's sigma, and 10 % of its
// span) between x's last reversal before the run (or the range's start) and the run: a dead band or a backlash
// holds the output from the input's reversal on (after a lag's few samples), and a hysteresis branch only steepens
// away from its reversal. A sensor that stopped updating, or a reading held, while the actuator moved on.
struct Stuck {
  std::size_t runs = 0, samples = 0;  // flagged runs and their samples
  std::size_t first = 0, last = 0;    // the longest flagged run [first, last)
  double value = 0.0, moved = 0.0;    // y there, and the most x moves during a flagged run
  std::size_t reference = 0;          // the longest run it was compared with (the 1 % longest left out)
  // stuck_input_runs: the most y moves during the other runs of one x value, and the reading's jump at the end of
  // the longest flagged run
  double other_moves = 0.0, jump = 0.0;
  std::vector<IndexRange> flagged;  // every flagged run, in order
};
Stuck stuck_runs(std::span<const double> y, std::span<const double> x, IndexRange range);

// A stuck input sensor: runs of x at one value inside its range by more than 10 % of its span (pinned_runs names
// clips at its least and largest values), at least 10x as long as the other runs of one x value there (leaving out
// the longest 1 %, as stuck_runs) and 10 samples or more, during which y moves (its range over the run) by more than
// 8 noise widths, 10 % of its span and 3x the most it moves during any of those other runs (a staircase's settling
// at each level), and after which the reading jumps, in one sample, by more than 10 % of x's span the way that
// explains y's net move, itself more than half y's range over the run (the sensor catching up with the input that
// moved on; a held command resumes where it was), unless the reading stepped into the run, in one sample, by more
// than 10 % of x's span, either way (a step test's or a staircase's held command, which y follows late, or behind a
// lag still goes on from before it; a stuck reading freezes where it was). Not at the range's start or end. "The
// way": the sign of x and y's covariance over the range. Stuck::value is x's value there, `moved` the most y moves
// in a flagged run. fit() warns, its status unchanged. (sensor_faults.cpp)
Stuck stuck_input_runs(std::span<const double> x, std::span<const double> y, IndexRange range);

// The texts of fit()'s and the scored records' stuck-sensor warnings: "sits exactly at ...: the output (input)
// sensor is stuck there ..." of a flagged Stuck over the range r. (sensor_faults.cpp)
std::string stuck_text(const Stuck& st, std::span<const double> x, IndexRange r);
std::string stuck_input_text(const Stuck& st, std::span<const double> x, std::span<const double> y, IndexRange r);
// The rows of a sensor fault fit() names: of the input (a clip, a stuck reading: the model, simulated through every
// sample from the record's start, holds the wrong input in its memory until the input sweeps its span) or of the
// output (the input was applied: the state after them is right).
using FaultRun = SensorFaultRun;
// fit()'s warning on where to train instead of every flagged row (runs: in order of their first sample): the longest
// stretch of the training range tr free of them, each stretch after an input fault starting only once x has been within 5 % of its span of one extreme of
// the range and then of the other (every play of threshold up to 0.45 span is then set by the input alone, whatever
// the wrong reading left; sweep_after); with the runs named (up to 6), "--train A:B", its share of the range, that
// a --validate range must leave them out where the default (the samples after --train) holds them, and where the
// stretch is under 10 % of the range, that it is; where its input reverses fewer than twice (as fit() counts them
// over it as a training range) and fewer times than over tr, that a fit there is blind to a branch or the inner
// loops; where its input covers less than half its span over tr, that a model fitted there extrapolates (and the
// stretch that covers the most, where it covers at least half and 1.5x as much). `train`: the stretch, none
// where no stretch is left. (sensor_faults.cpp)
struct ExcludeAdvice {
  std::string text;
  std::optional<IndexRange> train;
};
ExcludeAdvice exclude_advice(std::span<const FaultRun> runs, std::span<const double> x, IndexRange tr);
// The first sample in [from, end) by which x has come within 5 % of hi - lo of one of its extremes lo, hi (over the
// training range) and then of the other; `end` where it does not. (sensor_faults.cpp)
std::size_t sweep_after(std::span<const double> x, std::size_t from, std::size_t end, double lo, double hi);
// Samples of v[from, to) far outside the bulk of the rest (a glitch, a spike, a sensor's overrange value): "N
// sample(s) of the {which} lie far outside the rest (sample ...; 99 % of the samples lie within [lo, hi]): ...", ""
// where there are none. fit() refuses a training record with them; outlier_warning names them on a scored record,
// against the whole record's bulk (`bulk`: the samples whose quantiles set it, holding [from, to); default [from,
// to)). (sensor_faults.cpp)
std::string outliers_of(std::span<const double> v, std::size_t from, std::size_t to, std::string_view which,
                        std::optional<IndexRange> bulk = std::nullopt);
// fit()'s warnings on a coarse input or output sensor (grid_of) and whether the training RMS is near the output's
// floor. (sensor_faults.cpp)
std::vector<std::string> resolution_warnings(std::span<const double> x, std::span<const double> y, IndexRange tr,
                                             double rms);

// Runs fn(k) for k = 0..count-1, spread over up to `threads` threads (0: one per
// usable CPU; 1: in order on this thread). Each k must be independent, so the
// results do not depend on the thread count. The first exception (lowest k) is
// rethrown once all have finished. (lm.cpp)
void parallel_for(std::size_t count, int threads, const std::function<void(std::size_t)>& fn);
// Throws hysteron::Stopped where o.stop_requested says stop (FitOptions::stop_requested).
void check_stop(const FitOptions& o);

// auto's choice among candidates by hold-out score (least wins; NaN: no score): of the scores
// within `tie` of the least, the one with the fewest parameters (the first of equals).
// by_score: the least score's; both == score.size() if none has a score. (fit_api.cpp)
struct AutoChoice {
  std::size_t chosen = 0, by_score = 0;
};
AutoChoice auto_choice(std::span<const double> score, std::span<const std::size_t> num_parameters, double tie);

// A report with status invalid_input, the message, and the time since t0.
FitReport invalid_report(std::string message, FitModel kind, std::chrono::steady_clock::time_point t0);

// The least-squares line y = a x + b over a range: slope a and residual RMS.
struct LineFit {
  double slope = 0.0;
  double rms = 0.0;
};
LineFit straight_line(std::span<const double> x, std::span<const double> y, IndexRange range);

// The Levenberg-Marquardt identification of fit() on data already in model
// coordinates (fit() normalises the record, calls this, and maps the model back to
// raw units). With free_offset, the slope models (not the gpi of Eq. 8, whose c3 is
// its offset; not with the Huber loss) get a free output offset by variable
// projection, returned in the model's units map.
FitReport fit_core(std::span<const double> x, std::span<const double> y, const FitOptions& options,
                   bool free_offset);

// ---- test hooks (issue 13: `fit` memory) ----
// LM of the gpi and slope kinds on the compressed costs (default, true) or on the m
// residuals; returns the previous setting (lm.cpp; not thread-safe against running fits).
bool set_lm_compression(bool on);

// The least-squares problem LM is given at one point: its number of residuals, the cost
// 1/2 ||r||^2, the gradient J^T r and J^T J (residuals.cpp).
struct LmNormalEquations {
  long residuals = 0;
  double cost = 0.0;
  Eigen::VectorXd gradient;
  Eigen::MatrixXd jtj;
};
// Of the gpi cost in the chart (centre xc, half-span xs of the input) at the chart point of
// Eq. 13's theta, full or compressed.
LmNormalEquations gpi_normal_equations(std::span<const double> theta, int n, double xc, double xs,
                                       std::span<const double> x, std::span<const double> y, IndexRange train,
                                       InitialState initial, double huber, bool free_offset, bool compressed);
// Of the cost of a slope layout (as slope_residuals), full or compressed.
LmNormalEquations slope_normal_equations(FitModel model, std::span<const double> theta, std::span<const double> r,
                                         std::span<const double> zp, std::span<const double> zn,
                                         std::span<const double> x, std::span<const double> y, IndexRange train,
                                         InitialState initial, double huber, bool free_offset, bool compressed);

// Of the bouc-wen cost (its LM parameters theta = [s, kw, rho, sigma, n, offset]; huber > 0:
// the robust residuals), full (ceres::AutoDiffCostFunction, m residuals) or compressed
// (kind_bouc_wen.cpp).
LmNormalEquations bouc_wen_normal_equations(std::span<const double> theta, std::span<const double> x,
                                            std::span<const double> y, IndexRange train, InitialState initial,
                                            double huber, bool compressed);

}  // namespace hysteron::detail
