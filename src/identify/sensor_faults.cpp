// The sensor-fault checks of fit() and of a scored record (detail.hpp): a column that clips (pinned_runs), a stuck
// output or input sensor (stuck_runs, stuck_input_runs), a coarse sensor's resolution (grid_of,
// resolution_warnings), their warnings' texts and where to train instead (exclude_advice).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "detail.hpp"

namespace hysteron {

namespace {

// pinned_runs's bound (detail.hpp): multiples of the most b moves during another run of a and of b's noise, and a
// fraction of b's span.
constexpr double kPinnedRatio = 3.0, kPinnedNoise = 8.0, kPinnedSpan = 0.1;
// ... and b must turn back inside the run by more than this fraction of its range there (and 8 noise widths): a
// clipped sine 58 %, Festo test8 clipped at 90 % 14 %; an output settling at a rest 0-1 % (the review's records).
constexpr double kPinnedTurn = 0.05;
// A column on at most this many levels over the training range (6 bits) has a coarse resolution: its step is at
// least 1/63 of its span, and step / sqrt(12) at least 0.46 % of it, as much as a model leaves on a good record.
constexpr std::size_t kCoarseLevels = 64;
// A fit whose RMS is within this factor of the resolution's floor is limited by it (the floor is then at least
// 64 % of its mean square error).
constexpr double kResolutionNear = 1.25;
// A coarse input is a sensor's reading (not a held command, a staircase) when the output, over the second half of
// the input's runs at one level, drifts (the mean of the last quarter less that of the third) by at least this
// fraction of what one step means (step x mean slope) on average.
constexpr double kHeldMoves = 0.25;

// f(s, e) for each run [s, e) of equal values of a over r.
template <class F>
void for_each_run(std::span<const double> a, IndexRange r, F f) {
  for (std::size_t s = r.begin, e; s < r.end; s = e) {
    for (e = s + 1; e < r.end && a[e] == a[s];) ++e;
    f(s, e);
  }
}

// b's least and largest values over [s, e)
std::pair<double, double> minmax_of(std::span<const double> b, std::size_t s, std::size_t e) {
  const auto [l, h] = std::minmax_element(b.begin() + static_cast<std::ptrdiff_t>(s),
                                          b.begin() + static_cast<std::ptrdiff_t>(e));
  return {*l, *h};
}

// stuck_runs, stuck_input_runs (detail.hpp): a run at least this many times as long as the other runs of one value.
constexpr double kStuckRatio = 10.0;

// The runs of one value of v over r whose value `keep` accepts, for the stuck-sensor rules: a run is long where it
// is at least kStuckRatio times its reference, the longest other such run leaving out the longest 1 % (so that a
// second stuck stretch does not hide the first), at least 1 (so 10 samples or more).
class RunLengths {
 public:
  template <class Keep>
  RunLengths(std::span<const double> v, IndexRange r, Keep keep) {
    for_each_run(v, r, [&](std::size_t s, std::size_t e) {
      if (keep(v[s])) sorted_.push_back(e - s);
    });
    std::sort(sorted_.begin(), sorted_.end(), std::greater<>());
  }
  std::size_t reference(std::size_t len) const {
    const std::size_t k = sorted_.size() / 100;
    const std::size_t at = k < sorted_.size() && len >= sorted_[k] ? k + 1 : k;
    return std::max<std::size_t>(at < sorted_.size() ? sorted_[at] : 0, 1);
  }
  bool long_run(std::size_t len) const {
    return static_cast<double>(len) >= kStuckRatio * static_cast<double>(reference(len));
  }

 private:
  std::vector<std::size_t> sorted_;  // longest first
};

}  // namespace

detail::Grid detail::grid_of(std::span<const double> v) {
  std::vector<double> s(v.begin(), v.end());
  std::sort(s.begin(), s.end());
  if (s.empty()) return {};
  const double lo = s.front(), hi = s.back(), tol = 1e-9 * std::max(std::abs(lo), std::abs(hi));
  double gap = hi - lo;  // the least spacing of distinct values
  for (std::size_t k = 1; k < s.size(); ++k)
    if (s[k] - s[k - 1] > tol) gap = std::min(gap, s[k] - s[k - 1]);
  const double m = std::round((hi - lo) / gap);  // steps across the span
  if (!(m >= 1) || static_cast<double>(s.size()) < 4 * (m + 1)) return {};
  const double q = (hi - lo) / m;
  for (double x : s)
    if (std::abs((x - lo) / q - std::round((x - lo) / q)) > 0.1) return {};
  return {q, static_cast<std::size_t>(m) + 1};
}

std::array<detail::Pinned, 2> detail::pinned_runs(std::span<const double> a, std::span<const double> b,
                                                  IndexRange r) {
  const auto [lo, hi] = minmax_of(a, r.begin, r.end);
  const auto [blo, bhi] = minmax_of(b, r.begin, r.end);
  double moves = 0.0;
  std::size_t holds = 0;
  for_each_run(a, r, [&](std::size_t s, std::size_t e) {
    if (a[s] == lo || a[s] == hi) return;
    const auto [l, h] = minmax_of(b, s, e);
    moves = std::max(moves, h - l);
    holds += e - s >= 2;
  });
  const double sigma = detect_clipping(b.subspan(r.begin, r.end - r.begin)).sigma;
  const double bound = std::max({kPinnedRatio * moves, kPinnedNoise * sigma, kPinnedSpan * (bhi - blo)});
  std::array<Pinned, 2> out;
  for (int k : {0, 1}) out[k].value = k ? hi : lo, out[k].moves = moves, out[k].holds = holds;
  for_each_run(a, r, [&](std::size_t s, std::size_t e) {
    if (e - s < 3 || (a[s] != lo && a[s] != hi)) return;
    const auto [l, h] = minmax_of(b, s, e);
    Pinned& p = out[a[s] == hi ? 1 : 0];
    if (!(h - l > bound)) return;
    // a clip hides an excursion beyond the limit and back, so b turns back inside the run: its extreme lies beyond
    // both ends of the run; a rest or hold there (a vented muscle, a commanded 0) lets b settle monotonically
    const double turn = std::max(h - std::max(b[s], b[e - 1]), std::min(b[s], b[e - 1]) - l);
    if (!(turn > std::max(kPinnedNoise * sigma, kPinnedTurn * (h - l)))) return;
    if (p.samples == 0) p.first = s, p.last = e;
    p.samples += e - s;
    p.flagged.push_back({s, e});
    p.moved = std::max(p.moved, h - l);
  });
  return out;
}

detail::Stuck detail::stuck_runs(std::span<const double> y, std::span<const double> x, IndexRange r) {
  Stuck out;
  if (r.end - r.begin < 3) return out;
  const auto [lo, hi] = minmax_of(y, r.begin, r.end);
  const double sx = span_of(x.subspan(r.begin, r.end - r.begin)), sy = hi - lo;
  if (!(sx > 0) || !(sy > 0)) return out;
  // inside the output's range by more than 10 % of its span: a dead zone or a stop rests at (about) an extreme
  const auto inside = [&](double v) { return v - lo > kPinnedSpan * sy && hi - v > kPinnedSpan * sy; };
  std::vector<std::size_t> turns;  // the input's reversals (by 10 % of its span), in order
  for (const auto& [k, dir] : detail::reversals(x, r.begin, r.end, sx)) turns.push_back(k);
  // the output's noise (detect_clipping's sigma) times 8, as pinned_runs; 0 without noise
  const double sigma = detect_clipping(y.subspan(r.begin, r.end - r.begin)).sigma;
  const double noise = std::isfinite(sigma) ? kPinnedNoise * sigma : 0.0;
  const RunLengths runs(y, r, inside);
  std::size_t longest_flagged = 0;
  for_each_run(y, r, [&](std::size_t s, std::size_t e) {
    const std::size_t len = e - s;
    if (!inside(y[s]) || !runs.long_run(len)) return;
    const std::size_t ref = runs.reference(len);
    const auto [xl, xh] = minmax_of(x, s, e);
    const double net = x[e - 1] - x[s];
    if (!(xh - xl > kPinnedSpan * sx) || !(std::abs(net) > 0.5 * (xh - xl))) return;
    // the output moved since the input's last reversal before the run (or the record's start): a play's dead
    // band or a backlash holds the output from the reversal on, and a branch only steepens away from it
    const auto after = std::upper_bound(turns.begin(), turns.end(), s);
    if (after != turns.end() && *after < e) return;  // the input turns inside the run
    const std::size_t t = after == turns.begin() ? r.begin : *(after - 1);
    const auto [yl, yh] = minmax_of(y, t, s + 1);
    if (!(yh - yl > std::max(noise, kPinnedSpan * sy))) return;
    ++out.runs;
    out.samples += len;
    out.flagged.push_back({s, e});
    out.moved = std::max(out.moved, xh - xl);
    if (len > longest_flagged) longest_flagged = len, out.first = s, out.last = e, out.value = y[s], out.reference = ref;
  });
  return out;
}

detail::Stuck detail::stuck_input_runs(std::span<const double> x, std::span<const double> y, IndexRange r) {
  Stuck out;
  if (r.end - r.begin < 3) return out;
  const auto [lo, hi] = minmax_of(x, r.begin, r.end);
  const double sx = hi - lo, sy = span_of(y.subspan(r.begin, r.end - r.begin));
  if (!(sx > 0) || !(sy > 0)) return out;
  // inside the input's range by more than 10 % of its span: a clip sits at an extreme (pinned_runs)
  const auto inside = [&](double v) { return v - lo > kPinnedSpan * sx && hi - v > kPinnedSpan * sx; };
  const RunLengths runs(x, r, inside);
  // the most y moves during the other runs (a held command's settling or creep, a coarse sensor's step)
  double moves = 0.0;
  for_each_run(x, r, [&](std::size_t s, std::size_t e) {
    if (!inside(x[s]) || runs.long_run(e - s)) return;
    const auto [l, h] = minmax_of(y, s, e);
    moves = std::max(moves, h - l);
  });
  const double sigma = detect_clipping(y.subspan(r.begin, r.end - r.begin)).sigma;
  const double noise = std::isfinite(sigma) ? kPinnedNoise * sigma : 0.0;
  const double bound = std::max({kPinnedRatio * moves, noise, kPinnedSpan * sy});
  // the way y goes with x over the range (the sign of their covariance; 0: none), to tell which jump of the reading
  // explains y's move during a run
  double mx = 0.0, my = 0.0, cov = 0.0;
  for (std::size_t j = r.begin; j < r.end; ++j) mx += x[j], my += y[j];
  mx /= static_cast<double>(r.end - r.begin), my /= static_cast<double>(r.end - r.begin);
  for (std::size_t j = r.begin; j < r.end; ++j) cov += (x[j] - mx) * (y[j] - my);
  const double way = cov > 0 ? 1.0 : cov < 0 ? -1.0 : 0.0;
  // a jump of the reading by more than 10 % of x's span that explains y's net move dy (any way where there is none)
  const auto explains = [&](double jump, double dy) {
    return std::abs(jump) > kPinnedSpan * sx && (way == 0.0 || jump * way * dy > 0.0);
  };
  std::size_t longest_flagged = 0;
  for_each_run(x, r, [&](std::size_t s, std::size_t e) {
    const std::size_t len = e - s;
    // a run at the range's start or end has no move into it or out of it to judge by
    if (s == r.begin || e == r.end || !inside(x[s]) || !runs.long_run(len)) return;
    const auto [l, h] = minmax_of(y, s, e);
    if (!(h - l > bound)) return;
    const double dy = y[e - 1] - y[s];
    if (!(std::abs(dy) > 0.5 * (h - l))) return;  // y moved mostly one way (not a ringing's phase at the end)
    // the sensor catching up: the reading jumps at the run's end, in one sample, the way y went meanwhile (a held
    // command resumes where it was, and y settles or creeps during it whichever way)
    const double exit = x[e] - x[e - 1];
    if (!explains(exit, dy)) return;
    // ... unless the reading stepped into the run, in one sample, by more than 10 % of x's span, either way: a step
    // test's or a staircase's held command, which y follows late (the way of the step) or behind a lag still goes
    // on from before it (the other way); a stuck reading freezes where it was
    const double entry = x[s] - x[s - 1];
    if (std::abs(entry) > kPinnedSpan * sx) return;
    ++out.runs;
    out.samples += len;
    out.flagged.push_back({s, e});
    out.moved = std::max(out.moved, h - l);
    if (len > longest_flagged)
      longest_flagged = len, out.first = s, out.last = e, out.value = x[s], out.reference = runs.reference(len),
      out.jump = exit;
  });
  out.other_moves = moves;
  return out;
}

namespace detail {

// "sits exactly at ...: the output sensor is stuck there (or its reading was held)" of a flagged Stuck
std::string stuck_text(const detail::Stuck& st, std::span<const double> x, IndexRange r) {
  const double sx = detail::span_of(x.subspan(r.begin, r.end - r.begin));
  return fmt::format(
      "sits exactly at {:.6g} for {} samples (samples {}:{}{}) while the input moves on one way by up to {:.4g} "
      "({:.3g} % of its span), and the other runs of one output value inside its range are at most {} samples "
      "long (but the longest 1 %): the output sensor is stuck there (or its reading was held)",
      st.value, st.last - st.first, st.first, st.last,
      st.runs > 1 ? fmt::format("; {} such runs, {} samples in all", st.runs, st.samples) : "", st.moved,
      100 * st.moved / sx, st.reference);
}

// "sits exactly at ...: the input sensor is stuck there (or its reading was held)" of a flagged input Stuck
std::string stuck_input_text(const detail::Stuck& st, std::span<const double> x, std::span<const double> y,
                             IndexRange r) {
  const double sx = detail::span_of(x.subspan(r.begin, r.end - r.begin));
  const double sy = detail::span_of(y.subspan(r.begin, r.end - r.begin));
  return fmt::format(
      "sits exactly at {:.6g} for {} samples (samples {}:{}{}) while the output moves by up to {:.4g} ({:.3g} % of "
      "its span), and the reading then jumps by {:.4g} ({:.3g} % of its span) the way the output moved; {}: the "
      "input sensor is stuck there (or its reading was held while the input moved on)",
      st.value, st.last - st.first, st.first, st.last,
      st.runs > 1 ? fmt::format("; {} such runs, {} samples in all", st.runs, st.samples) : "", st.moved,
      100 * st.moved / sy, st.jump, 100 * std::abs(st.jump) / sx,
      st.reference > 1 ? fmt::format("during the other runs of one input value inside its range (at most {} samples "
                                     "long, but the longest 1 %) it moves by at most {:.4g}",
                                     st.reference, st.other_moves)
                       : std::string("the input holds no other value inside its range for two samples or more (but "
                                     "the longest 1 % of its runs)"));
}

// sweep_after's band: within this fraction of x's span of an extreme.
constexpr double kSweepBand = 0.05;
// exclude_advice: a stretch under this share of the training range is said to be short.
constexpr double kShortStretch = 0.1;
// ... and one whose input covers less than this share of its span over the training range, narrow.
constexpr double kNarrowStretch = 0.5;

std::size_t sweep_after(std::span<const double> x, std::size_t from, std::size_t end, double lo, double hi) {
  const double band = kSweepBand * (hi - lo);
  int seen = 0;  // the extreme reached first: -1 the least, +1 the largest
  for (std::size_t k = from; k < end; ++k) {
    const int at = x[k] <= lo + band ? -1 : x[k] >= hi - band ? 1 : 0;
    if (at == 0) continue;
    if (seen == 0) seen = at;
    else if (at != seen) return k;
  }
  return end;
}

ExcludeAdvice exclude_advice(std::span<const FaultRun> runs, std::span<const double> x, IndexRange tr) {
  const auto [lo, hi] = minmax_of(x, tr.begin, tr.end);  // the extremes an input fault's sweep reaches
  IndexRange best{tr.begin, tr.begin};
  bool best_swept = false;
  std::size_t at = tr.begin;  // where a stretch after the runs so far may start
  bool swept = false;         // ... set by an input fault's sweep
  std::vector<IndexRange> stretches;  // every stretch free of the runs
  const auto consider = [&](std::size_t end) {
    if (end <= at) return;
    stretches.push_back({at, end});
    if (end - at > best.end - best.begin) best = {at, end}, best_swept = swept;
  };
  for (const FaultRun& f : runs) {
    consider(f.rows.begin);
    const std::size_t next = f.input ? sweep_after(x, std::max(f.rows.end, tr.begin), tr.end, lo, hi) : f.rows.end;
    if (next > at) at = next, swept = f.input && next > f.rows.end;
  }
  consider(tr.end);
  std::string list;
  for (std::size_t i = 0; i < runs.size() && i < 6; ++i)
    list += fmt::format("{}{}:{} ({})", i ? ", " : "", runs[i].rows.begin, runs[i].rows.end,
                        runs[i].input ? "input" : "output");
  if (runs.size() > 6) list += fmt::format(", and {} more", runs.size() - 6);
  const std::size_t n = best.end - best.begin, m = tr.end - tr.begin;
  if (n == 0)
    return {fmt::format("the rows the warnings above name (samples {}) leave no stretch of the training range free of "
                        "them{}: re-record",
                        list, swept ? " (after an input fault, the input must sweep its span before the model's "
                                      "memory is free of the wrong reading)" : ""),
            std::nullopt};
  std::string w = fmt::format(
      "to fit without the rows the warnings above name (samples {}): train on samples {}:{} (--train {}:{}, {:.3g} % of "
      "the training range), the longest stretch of it free of them{}",
      list, best.begin, best.end, best.begin, best.end, 100.0 * static_cast<double>(n) / static_cast<double>(m),
      best_swept ? ", from where the input has swept its span after an input fault (the model's memory holds the wrong "
                   "reading until then, and the errors there are the fault's)"
                 : "");
  if (best.end < tr.end)
    w += "; a --validate range must leave them out too (without one, the samples after --train are validated, and "
         "they hold them)";
  // fit()'s rule on the stretch as a training range (its own span): fewer than two reversals leave a branch or the
  // inner loops unseen; said where the training range had more (else fit()'s own warning says it of both)
  const std::size_t rev = reversals(x, best.begin, best.end, span_of(x.subspan(best.begin, n))).size();
  const bool loops_lost = rev < 2 && rev < reversals(x, tr.begin, tr.end, span_of(x.subspan(tr.begin, m))).size();
  const bool short_stretch = static_cast<double>(n) < kShortStretch * static_cast<double>(m);
  if (short_stretch)
    w += fmt::format("; that is less than {:.0f} % of the training range", 100 * kShortStretch);
  if (loops_lost)
    w += fmt::format("; the input {} there (by more than {:.0f} % of its span there), so a fit on it sees {}",
                     rev == 0 ? "never reverses" : "reverses once", 100 * kReversalFraction,
                     rev == 0 ? "one branch only" : "no inner (minor) loop");
  // the share of the training range's input span a stretch covers: a model fitted there extrapolates beyond it
  const auto coverage = [&](IndexRange r) {
    const auto [a, b] = minmax_of(x, r.begin, r.end);
    return hi > lo ? (b - a) / (hi - lo) : 1.0;
  };
  const double covered = coverage(best);
  const bool narrow = covered < kNarrowStretch;
  if (narrow) {
    const auto [a, b] = minmax_of(x, best.begin, best.end);
    w += fmt::format("; the input covers only {:.3g} % of its span over the training range there ({:.6g} to {:.6g} of "
                     "{:.6g} to {:.6g}), and a model fitted there extrapolates beyond it",
                     100 * covered, a, b, lo, hi);
    IndexRange wide = best;  // the stretch that covers the most, if much more
    for (const IndexRange& r : stretches)
      if (coverage(r) > coverage(wide)) wide = r;
    if (coverage(wide) >= std::max(kNarrowStretch, 1.5 * covered))
      w += fmt::format("; the stretch that covers the most is samples {}:{} (--train {}:{}, {:.3g} % of the training "
                       "range, {:.3g} % of the span)",
                       wide.begin, wide.end, wide.begin, wide.end,
                       100.0 * static_cast<double>(wide.end - wide.begin) / static_cast<double>(m),
                       100 * coverage(wide));
  }
  if (short_stretch || loops_lost || narrow) w += ": re-record, or fit it knowing how little it holds";
  return {std::move(w), best};
}


}  // namespace detail

std::string stuck_input_warning(std::span<const double> x, std::span<const double> y, IndexRange range,
                                std::string_view what) {
  detail::check_record(x, y, "stuck_input_warning");
  const IndexRange r = detail::check_range(range, x.size(), "stuck_input_warning");
  const detail::Stuck st = detail::stuck_input_runs(x, y, r);
  if (st.runs == 0) return {};
  return fmt::format("{}: the input {}; if so, the model is driven there by an input that was not applied: leave "
                     "these rows out of the scored range",
                     what, stuck_input_text(st, x, y, r));
}

std::string stuck_output_warning(std::span<const double> x, std::span<const double> y, IndexRange range,
                                 std::string_view what) {
  detail::check_record(x, y, "stuck_output_warning");
  const IndexRange r = detail::check_range(range, x.size(), "stuck_output_warning");
  const detail::Stuck st = detail::stuck_runs(y, x, r);
  if (st.runs == 0) return {};
  return fmt::format("{}: the output {}; the model's score there is the sensor's: leave these rows out of the "
                     "scored range",
                     what, stuck_text(st, x, r));
}

namespace detail {

// The warnings on the sensors' resolution (grid_of, detail.hpp): a column on at most kCoarseLevels levels, the
// RMS error that step alone leaves (step / sqrt(12); for the input, in the output's units through the record's
// mean slope span(y) / span(x), and only where the output keeps moving while the input holds a level: a sensor's
// reading, not a held command; an estimate: the local slope and where the input dwells change it), and whether the
// fit's training RMS is near the output's floor.
std::vector<std::string> resolution_warnings(std::span<const double> x, std::span<const double> y, IndexRange tr,
                                             double rms) {
  std::vector<std::string> out;
  const auto xt = x.subspan(tr.begin, tr.end - tr.begin), yt = y.subspan(tr.begin, tr.end - tr.begin);
  const double sx = detail::span_of(xt), sy = detail::span_of(yt), root12 = std::sqrt(12.0);
  const detail::Grid gy = detail::grid_of(yt), gx = detail::grid_of(xt);
  const auto coarse = [](const detail::Grid& g) { return g.levels > 0 && g.levels <= kCoarseLevels; };
  if (coarse(gy)) {
    const double floor = gy.step / root12;
    out.push_back(fmt::format("the output is recorded on {} levels over the training range (step {:.4g}, {:.3g} % "
                              "of its span): that resolution alone leaves an RMS error of about step/sqrt(12) = "
                              "{:.4g} ({:.3g} % of the span)",
                              gy.levels, gy.step, 100 * gy.step / sy, floor, 100 * floor / sy));
    if (rms <= kResolutionNear * floor)
      out.push_back(fmt::format("the fit's training RMS {:.4g} is within {}x of {:.4g}, what the output sensor's "
                                "resolution alone leaves: the fit is limited by the sensor's resolution rather than "
                                "by the model; a sensor with finer steps over the signal's span would let it go lower",
                                rms, kResolutionNear, floor));
  }
  if (!coarse(gx)) return out;
  // the output's drift over the second half of the input's runs (at least 8 samples): twice the mean of their last
  // quarter less that of their third (a trend, not the noise's range; a ramp's change over the half)
  double held = 0.0;
  std::size_t runs = 0;
  const auto mean = [&](std::size_t a, std::size_t b) {
    double m = 0.0;
    for (std::size_t k = a; k < b; ++k) m += y[k];
    return m / static_cast<double>(b - a);
  };
  for_each_run(x, tr, [&](std::size_t s, std::size_t e) {
    if (e - s < 8) return;
    const std::size_t q = (e - s) / 4;
    held += 2.0 * std::abs(mean(e - q, e) - mean(e - 2 * q, e - q)), ++runs;
  });
  const double per_step = gx.step * sy / sx;  // the output's change over one input step, at the mean slope
  // never a floor above what the fit reached
  if (runs > 0 && held / static_cast<double>(runs) >= kHeldMoves * per_step)
    out.push_back(fmt::format("the input is recorded on {} levels over the training range (step {:.4g}, {:.3g} % of "
                              "its span), and the output keeps moving while the input holds a level (a sensor's "
                              "resolution, not a held command): that alone leaves an RMS error of up to about "
                              "{:.4g} in the output ({:.3g} % of its span; step/sqrt(12) times the record's mean "
                              "slope {:.4g}, an estimate: the fit's training RMS is {:.4g})",
                              gx.levels, gx.step, 100 * gx.step / sx, per_step / root12,
                              100 * per_step / root12 / sy, sy / sx, rms));
  return out;
}

}  // namespace detail

// The reversals of x over [from, to) (by more than detail::kReversalFraction of span): the sample of
// each turning extremum and +1 for a maximum, -1 for a minimum.
std::vector<std::pair<std::size_t, int>> detail::reversals(std::span<const double> x, std::size_t from, std::size_t to,
                                                   double span) {
  const double h = detail::kReversalFraction * span;
  std::vector<std::pair<std::size_t, int>> out;
  int dir = 0;  // +1 rising, -1 falling, 0 not yet known (the first move is no reversal)
  std::size_t ihi = from, ilo = from;
  for (std::size_t k = from + 1; k < to; ++k) {
    const double v = x[k];
    if (dir == 0) {
      if (v > x[ihi]) ihi = k;
      if (v < x[ilo]) ilo = k;
      if (v < x[ihi] - h) dir = -1, ilo = k;
      else if (v > x[ilo] + h) dir = 1, ihi = k;
    } else if (dir > 0) {
      if (v > x[ihi]) ihi = k;
      else if (v < x[ihi] - h) out.emplace_back(ihi, 1), dir = -1, ilo = k;
    } else {
      if (v < x[ilo]) ilo = k;
      else if (v > x[ilo] + h) out.emplace_back(ilo, -1), dir = 1, ihi = k;
    }
  }
  return out;
}

// Samples of v[from, to) far outside the bulk of the rest, beyond the range of its central 99 %
// (its 0.5 % and 99.5 % quantiles) by more than half that range's width: a glitch, a spike or a
// sensor's overrange value (9.9e37). A run of such samples is one when it is short (at most 5
// samples or 0.05 % of them) inside the range and jumps there and back by more than that half
// width in one sample each way, or when it lies beyond the bulk by more than 10 of its widths
// anywhere. Never the peaks of a smooth signal (its top 0.5 % of samples lie within a small
// fraction of its span of each other), a rest at the start or the end, a step from rest, or a
// vent of more than a few samples. The description names the count and the first rows; empty
// where there are none. The bulk (the quantiles, a short run's length, the samples a spike jumps from and back to)
// is that of v[bulk] where bulk is given (it holds [from, to)), else of v[from, to).
std::string detail::outliers_of(std::span<const double> v, std::size_t from, std::size_t to, std::string_view which,
                                std::optional<IndexRange> bulk_rows) {
  const IndexRange bulk = bulk_rows.value_or(IndexRange{from, to});
  std::vector<double> s(v.begin() + static_cast<std::ptrdiff_t>(bulk.begin),
                        v.begin() + static_cast<std::ptrdiff_t>(bulk.end));
  const std::size_t n = s.size();
  const auto at = [&](double q) {
    const auto k = static_cast<std::size_t>(q * static_cast<double>(n - 1));
    std::nth_element(s.begin(), s.begin() + static_cast<std::ptrdiff_t>(k), s.end());
    return s[k];
  };
  const double lo = at(0.005), hi = at(0.995);
  const double margin = 0.5 * (hi - lo);
  if (!(margin > 0.0)) return {};  // a column constant over 99 % of the record: nothing to tell them by
  const auto beyond = [&](std::size_t k) { return v[k] < lo - margin || v[k] > hi + margin; };
  std::size_t count = 0;
  std::string rows;
  const std::size_t short_run = std::max<std::size_t>(5, n / 2000);
  for (std::size_t a = from; a < to; ++a) {
    if (!beyond(a)) continue;
    std::size_t b = a;  // the run [a, b)
    double far = 0.0;   // its farthest distance beyond the bulk
    while (b < to && beyond(b)) far = std::max({far, lo - v[b], v[b] - hi}), ++b;
    const bool spike = a > bulk.begin && b < bulk.end && b - a <= short_run && std::abs(v[a] - v[a - 1]) > margin &&
                       std::abs(v[b - 1] - v[b]) > margin;
    if (spike || far > 20.0 * margin)
      for (std::size_t k = a; k < b; ++k)
        if (++count <= 5) rows += fmt::format("{}{} ({:.6g})", rows.empty() ? "" : ", ", k, v[k]);
    a = b;
  }
  if (count == 0) return {};
  return fmt::format("{} sample(s) of the {} lie far outside the rest (sample {}{}; 99 % of the samples lie "
                     "within [{:.6g}, {:.6g}]): a glitch, a spike or a sensor's overrange value",
                     count, which, rows, count > 5 ? ", ..." : "", lo, hi);
}

std::size_t input_reversals(std::span<const double> x, IndexRange range) {
  const IndexRange r = detail::check_range(range, x.size(), "input_reversals");
  return detail::reversals(x, r.begin, r.end, detail::span_of(x.subspan(r.begin, r.end - r.begin))).size();
}

std::string outlier_warning(std::span<const double> x, std::span<const double> y, IndexRange range,
                            std::string_view what) {
  detail::check_record(x, y, "outlier_warning");
  const IndexRange r = detail::check_range(range, x.size(), "outlier_warning");
  if (r.end - r.begin < 2) return {};
  // against the whole record's bulk (a quiet stretch's noise is no spike), the input's over every sample the model
  // is driven by (from the record's start), the output's over the scored range
  const IndexRange all{0, x.size()};
  const std::string in = detail::outliers_of(x, 0, r.end, "input", all);
  const std::string out = detail::outliers_of(y, r.begin, r.end, "output", all);
  if (in.empty() && out.empty()) return {};
  std::string w = fmt::format("{}: ", what);
  if (!in.empty())
    w += in + "; the model is driven by them, and its memory after them, so the errors there and after are theirs";
  if (!out.empty())
    w += (in.empty() ? "" : "; ") + out + "; the errors there are theirs";
  return w + ": repair them or leave them out of the scored range (fit refuses a training record with them)";
}

}  // namespace hysteron
