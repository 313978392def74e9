// Error metrics, record simulation and input checks of the identification tools.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <vector>

#include "detail.hpp"
#include "hysteron/error.hpp"

namespace hysteron {

namespace detail {

void check_record(std::span<const double> x, std::span<const double> y, std::string_view what) {
  if (x.size() != y.size())
    throw Error(fmt::format("{}: input has {} samples but output has {} (they must be equal)", what, x.size(), y.size()));
  if (x.empty()) throw Error(fmt::format("{}: the record is empty", what));
  for (std::size_t k = 0; k < x.size(); ++k) {
    if (!std::isfinite(x[k])) throw Error(fmt::format("{}: input sample {} is not finite ({})", what, k, x[k]));
    if (!std::isfinite(y[k])) throw Error(fmt::format("{}: output sample {} is not finite ({})", what, k, y[k]));
  }
}

IndexRange check_range(IndexRange range, std::size_t n, std::string_view what) {
  const IndexRange r = range.resolved(n);
  if (r.end > n || r.begin >= r.end)
    throw Error(fmt::format("{}: sample range [{}, {}) is empty or outside the record of {} samples", what, r.begin,
                            range.end == IndexRange::npos ? n : range.end, n));
  return r;
}

double span_of(std::span<const double> v) {
  if (v.empty()) return 0.0;
  const auto [lo, hi] = std::minmax_element(v.begin(), v.end());
  return *hi - *lo;
}

FitReport invalid_report(std::string message, FitModel kind, std::chrono::steady_clock::time_point t0) {
  FitReport rep;
  rep.status = FitStatus::invalid_input;
  rep.model_kind = kind;
  rep.message = std::move(message);
  rep.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return rep;
}

LineFit straight_line(std::span<const double> x, std::span<const double> y, IndexRange r) {
  const double m = static_cast<double>(r.end - r.begin);
  double mx = 0, my = 0;
  for (std::size_t k = r.begin; k < r.end; ++k) mx += x[k], my += y[k];
  mx /= m, my /= m;
  double sxx = 0, sxy = 0, syy = 0;
  for (std::size_t k = r.begin; k < r.end; ++k)
    sxx += (x[k] - mx) * (x[k] - mx), sxy += (x[k] - mx) * (y[k] - my), syy += (y[k] - my) * (y[k] - my);
  LineFit f;
  f.slope = sxx > 0 ? sxy / sxx : 0.0;
  f.rms = std::sqrt((sxx > 0 ? std::max(0.0, syy - sxy * sxy / sxx) : syy) / m);
  return f;
}

}  // namespace detail

Clipping detect_clipping(std::span<const double> y) {
  Clipping c;
  if (y.size() < 100) return c;
  for (double v : y)
    if (!std::isfinite(v)) return c;
  const auto [lo_it, hi_it] = std::minmax_element(y.begin(), y.end());
  c.lo = *lo_it;
  c.hi = *hi_it;
  // the noise where the signal is off its limits (the clipped stretches have none)
  std::vector<double> d;
  d.reserve(y.size());
  for (std::size_t k = 0; k + 2 < y.size(); ++k)
    if (std::min({y[k], y[k + 1], y[k + 2]}) > c.lo && std::max({y[k], y[k + 1], y[k + 2]}) < c.hi)
      d.push_back(y[k + 2] - 2.0 * y[k + 1] + y[k]);
  if (d.size() < 50) return c;
  auto median = [](std::vector<double>& v) {
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  const double m = median(d);
  for (double& v : d) v = std::abs(v - m);
  c.sigma = 1.4826 * median(d) / std::sqrt(6.0);
  if (!(c.sigma > 0.0)) return c;
  const double band = 3.0 * c.sigma;
  std::size_t near_lo = 0, at_lo = 0, near_hi = 0, at_hi = 0;
  for (double v : y) {
    if (v <= c.lo + band) ++near_lo, at_lo += v == c.lo;
    if (v >= c.hi - band) ++near_hi, at_hi += v == c.hi;
  }
  c.low_share = static_cast<double>(at_lo) / static_cast<double>(near_lo);
  c.high_share = static_cast<double>(at_hi) / static_cast<double>(near_hi);
  c.low = at_lo >= 50 && c.low_share > 0.75;
  c.high = at_hi >= 50 && c.high_share > 0.75;
  return c;
}

std::vector<double> censored_output(std::span<const double> y, std::span<const double> predicted,
                                    const Clipping& clip, std::size_t* replaced) {
  if (y.size() != predicted.size())
    throw Error(fmt::format("censored_output: {} outputs but {} predictions", y.size(), predicted.size()));
  std::vector<double> out(y.begin(), y.end());
  std::size_t n = 0;
  for (std::size_t k = 0; k < y.size(); ++k) {
    const double p = predicted[k];
    if (!std::isfinite(p)) continue;
    if ((clip.low && y[k] == clip.lo && p < clip.lo) || (clip.high && y[k] == clip.hi && p > clip.hi)) {
      out[k] = p;
      ++n;
    }
  }
  if (replaced) *replaced = n;
  return out;
}

FitMetrics compute_metrics(std::span<const double> measured, std::span<const double> predicted) {
  if (measured.size() != predicted.size())
    throw Error(fmt::format("metrics: measured has {} samples but predicted has {}", measured.size(), predicted.size()));
  FitMetrics m;
  m.n = measured.size();
  if (m.n == 0) return m;
  // Sums of squares are taken of values divided by their largest magnitude, so
  // records around 1e-300 or 1e300 give the same metrics (times the scale) as
  // unit-scaled ones instead of underflowing to 0 or overflowing to inf.
  const double nn = static_cast<double>(m.n);
  double y_scale = 0.0;
  for (std::size_t k = 0; k < m.n; ++k) {
    const double e = measured[k] - predicted[k];
    m.max = std::max(m.max, std::abs(e));
    y_scale = std::max(y_scale, std::abs(measured[k]));
  }
  double mean = 0.0;  // of measured / y_scale
  if (y_scale > 0)
    for (double v : measured) mean += (v / y_scale) / nn;
  double sse = 0.0, sae = 0.0, sst = 0.0;  // of e / max, |e| / max, (y - mean) / y_scale
  const double e_scale = m.max;
  for (std::size_t k = 0; k < m.n; ++k) {
    if (e_scale > 0) {
      const double e = (measured[k] - predicted[k]) / e_scale;
      sse += e * e;
      sae += std::abs(e);
    }
    if (y_scale > 0) {
      const double d = measured[k] / y_scale - mean;
      sst += d * d;
    }
  }
  m.rms = e_scale * std::sqrt(sse / nn);
  m.mae = e_scale * (sae / nn);
  const double span = detail::span_of(measured);
  m.rms_percent_span = span > 0 ? 100.0 * (m.rms / span) : std::numeric_limits<double>::quiet_NaN();
  // 1 - SSE / SST with SSE = e_scale^2 sse and SST = y_scale^2 sst.
  // (a constant output has no variance to explain: its sst is only the mean's rounding)
  m.r2 = sst > 0 && span > 0 ? 1.0 - (e_scale / y_scale) * (e_scale / y_scale) * (sse / sst) : std::numeric_limits<double>::quiet_NaN();
  return m;
}

std::vector<double> simulate_record(const ModelParams& params, std::span<const double> x, InitialState initial) {
  Model model(params);
  if (initial == InitialState::relaxed && !x.empty()) model.reset_relaxed(x[0]);
  return model.simulate(x);
}

FitMetrics evaluate(const ModelParams& params, std::span<const double> x, std::span<const double> y, IndexRange range,
                    InitialState initial) {
  detail::check_record(x, y, "evaluate");
  const IndexRange r = detail::check_range(range, x.size(), "evaluate");
  const std::vector<double> yp = simulate_record(params, x, initial);
  return compute_metrics(y.subspan(r.begin, r.end - r.begin),
                         std::span<const double>(yp).subspan(r.begin, r.end - r.begin));
}

std::vector<double> censor_clipped(std::span<const double> y, std::span<const double> predicted, IndexRange detect_on,
                                   std::size_t* replaced) {
  const IndexRange r = detail::check_range(detect_on, y.size(), "censor_clipped");
  // (nothing clipped: censored_output returns y, 0 replaced, after the same length check)
  return censored_output(y, predicted, detect_clipping(y.subspan(r.begin, r.end - r.begin)), replaced);
}

FitMetrics evaluate_scored(const ModelParams& params, std::span<const double> x, std::span<const double> y,
                           IndexRange range, InitialState initial, bool censor, std::size_t* censored) {
  if (censor) return evaluate_censored(params, x, y, range, initial, censored);
  if (censored) *censored = 0;
  return evaluate(params, x, y, range, initial);
}

FitMetrics evaluate_censored(const ModelParams& params, std::span<const double> x, std::span<const double> y,
                             IndexRange range, InitialState initial, std::size_t* censored) {
  detail::check_record(x, y, "evaluate");
  const IndexRange r = detail::check_range(range, x.size(), "evaluate");
  const std::vector<double> yp = simulate_record(params, x, initial);
  const std::vector<double> yc = censor_clipped(y, yp);
  if (censored) {
    *censored = 0;
    for (std::size_t k = r.begin; k < r.end; ++k) *censored += yc[k] != y[k] ? 1 : 0;
  }
  return compute_metrics(std::span<const double>(yc).subspan(r.begin, r.end - r.begin),
                         std::span<const double>(yp).subspan(r.begin, r.end - r.begin));
}

InputCoverage input_coverage(const ModelParams& params, std::span<const double> x, IndexRange range) {
  InputCoverage c;
  c.limits = input_limits(params);
  const IndexRange r = detail::check_range(range, x.size(), "input_coverage");
  c.n = r.end - r.begin;
  if (!c.limits.bounded()) return c;
  const double tol = kInputCoverageTolerance * (c.limits.hi - c.limits.lo);
  double least = std::numeric_limits<double>::infinity(), largest = -least;
  for (std::size_t k = r.begin; k < r.end; ++k) {
    const double beyond = std::max(c.limits.lo - x[k], x[k] - c.limits.hi);
    if (beyond > tol) ++c.outside;
    c.max_beyond = std::max(c.max_beyond, beyond);
    least = std::min(least, x[k]);
    largest = std::max(largest, x[k]);
  }
  if (c.n > 0 && c.limits.hi > c.limits.lo) c.span_share = (largest - least) / (c.limits.hi - c.limits.lo);
  return c;
}

std::string input_coverage_warning(const InputCoverage& c, std::string_view what) {
  if (!(c.fraction() > 0.01)) return {};
  return fmt::format("{}: {} of the {} scored samples ({:.1f} %) have an input outside the model's input_limits "
                     "[{:.6g}, {:.6g}] (fit() sets them to its training range), up to {:.6g} beyond: the model "
                     "extrapolates there, and its score says as much about that range as about the model",
                     what, c.outside, c.n, 100.0 * c.fraction(), c.limits.lo, c.limits.hi, c.max_beyond);
}

OutputMap output_map(const ModelParams& params, std::span<const double> x, std::span<const double> y, IndexRange range,
                     InitialState initial, bool censor) {
  detail::check_record(x, y, "output_map");
  const IndexRange r = detail::check_range(range, x.size(), "output_map");
  OutputMap m;
  const std::vector<double> yp = simulate_record(params, x, initial);
  // the samples scored: every one, or those a clipping output does not censor (censor_clipped replaces them)
  std::vector<char> use(x.size(), 1);
  if (censor) {
    const std::vector<double> yc = censor_clipped(y, yp);
    for (std::size_t k = r.begin; k < r.end; ++k) use[k] = yc[k] == y[k];
  }
  std::size_t n = 0;
  double mp = 0.0, my = 0.0;
  for (std::size_t k = r.begin; k < r.end; ++k)
    if (use[k]) {
      ++n;
      mp += yp[k];
      my += y[k];
    }
  if (n < 2) return m;
  const double nd = static_cast<double>(n);
  mp /= nd;
  my /= nd;
  double spp = 0.0, spy = 0.0, syy = 0.0, see = 0.0;  // centred sums; see: the prediction's squared error
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (std::size_t k = r.begin; k < r.end; ++k) {
    if (!use[k]) continue;
    const double dp = yp[k] - mp, dy = y[k] - my;
    spp += dp * dp;
    spy += dp * dy;
    syy += dy * dy;
    see += (y[k] - yp[k]) * (y[k] - yp[k]);
    lo = std::min(lo, y[k]);
    hi = std::max(hi, y[k]);
  }
  if (!(spp > 0.0) || !(syy > 0.0) || !std::isfinite(spp) || !std::isfinite(syy) || !std::isfinite(see)) return m;
  m.gain = spy / spp;
  m.offset = my - m.gain * mp;
  m.r2 = 1.0 - see / syy;
  m.r2_mapped = std::min(1.0, spy / spp * spy / syy);
  double smm = 0.0;  // the map's squared error, summed directly (syy - spy^2 / spp cancels to sqrt(eps) * span)
  for (std::size_t k = r.begin; k < r.end; ++k) {
    if (!use[k]) continue;
    const double d = y[k] - (m.gain * yp[k] + m.offset);
    smm += d * d;
  }
  m.rms = std::sqrt(see / nd);
  m.rms_mapped = std::sqrt(smm / nd);
  m.span = hi - lo;
  return m;
}

bool output_map_explains(const OutputMap& m, double train_r2) {
  if (!(m.r2_mapped >= kMinFitR2)) return false;
  if (!std::isfinite(train_r2)) return true;
  return 1.0 - m.r2_mapped <= std::sqrt(std::max(0.0, 1.0 - train_r2));
}

bool validation_useless(const FitMetrics& validation, const FitMetrics& train, double input_share,
                        bool map_named) noexcept {
  // too narrow a stretch for R^2 to judge the model, unless a sign, unit or zero explains the record
  if (input_share < kNarrowInputShare && !map_named) return false;
  return validation.r2 <= 0.0 && validation.rms > kValidationRmsFactor * train.rms;
}

namespace {
// whether the map explains the record at all (a warning to give): a poor prediction, or one the map halves
bool output_map_poor(const OutputMap& m, double train_rms) {
  const bool poor = m.r2 < kMinFitR2;
  const bool halved = m.rms_mapped <= 0.5 * m.rms && m.rms > 0.01 * m.span;
  if (!poor && !halved) return false;
  // as well described as the training record: nothing to explain (a short or quiet stretch's R^2)
  return !(std::isfinite(train_rms) && !(m.rms > kValidationRmsFactor * train_rms));
}
}  // namespace

bool output_map_names(const OutputMap& m, double train_r2, double train_rms, double input_share) {
  if (!output_map_poor(m, train_rms)) return false;
  // a stretch too narrow for R^2, % of span or a map to say much: a sign, scale or zero is claimed only
  // where the map explains the record convincingly: it cuts the RMS error to at most 1 /
  // kValidationRmsFactor^2 of the prediction's (a flipped sign's error is twice the signal; on a narrow
  // stretch of a good record the map of two free numbers leaves 0.4-0.53 of it: Festo test8's own
  // 100-sample windows, whose maps' gains reach -4.5 at R^2 0.56), and with a training error to a mapped
  // RMS error within kValidationRmsFactor times it (a sign, scale or zero); without one only a flipped
  // sign (gain < 0, mapped R^2 at least kMinFitR2), never a scale or a zero
  if (input_share < kNarrowInputShare)
    return std::isfinite(m.gain) && m.rms_mapped * kValidationRmsFactor * kValidationRmsFactor <= m.rms &&
           (std::isfinite(train_rms) ? m.rms_mapped <= kValidationRmsFactor * train_rms
                                     : m.gain < 0.0 && m.r2_mapped >= kMinFitR2);
  return output_map_explains(m, train_r2);
}

std::string output_map_warning(const OutputMap& m, std::string_view what, double train_r2, double train_rms,
                               double input_share) {
  if (!output_map_poor(m, train_rms)) return {};
  const bool halved = m.rms_mapped <= 0.5 * m.rms && m.rms > 0.01 * m.span;
  const bool narrow = input_share < kNarrowInputShare;
  const bool named = output_map_names(m, train_r2, train_rms, input_share);
  if (narrow && !named)
    return fmt::format("{}: the prediction scores R^2 {:.4g} (RMS error {:.4g}, {:.3g} % of the output's span) on a "
                       "record whose input spans only {:.1f} % of the model's input range (input_limits): on so "
                       "narrow a stretch R^2 and % of span say little about the model{}",
                       what, m.r2, m.rms, m.span > 0.0 ? 100.0 * m.rms / m.span : std::nan(""), 100.0 * input_share,
                       std::isfinite(train_rms)
                           ? fmt::format("; its RMS error is {:.3g} times the training one ({:.4g})", m.rms / train_rms,
                                         train_rms)
                           : std::string(" (no training error to compare the RMS error with: the model file has no "
                                         "\"training\", which hysteron fit writes)"));
  if (named) {
    const std::string fit = fmt::format("the record's output matches {:.4g} x the model's prediction {:+.4g} (RMS "
                                        "error {:.4g}, R^2 {:.3f}, against {:.4g} and {:.4g} for the prediction as it "
                                        "is)",
                                        m.gain, m.offset, m.rms_mapped, m.r2_mapped, m.rms, m.r2);
    if (m.gain < 0.0)
      return fmt::format("{}: {}: the output runs against the model's; is its sign flipped (a sensor mounted the other "
                         "way, or the other signal's convention) relative to the record the model was fitted on?",
                         what, fit);
    return fmt::format("{}: {}: it differs from the record the model was fitted on by a scale (another unit, a gain) "
                       "or a zero (a sensor offset) more than by its hysteresis, or the actuator changed",
                       what, fit);
  }
  // no sign, scale or zero explains it: say so plainly, with the numbers, where the error is large
  // as far as known: more than kValidationRmsFactor times the training RMS error (a quiet stretch
  // has a poor R^2 on its small span where the model describes it as well as its training record),
  // or, without a training error (evaluate), where the map at least halves it
  if (!std::isfinite(train_rms) && !halved) return {};  // (with train_rms: beyond kValidationRmsFactor x it, above)
  const std::string train = std::isfinite(train_r2) ? fmt::format(" against R^2 {:.4g} in training", train_r2)
                                                    : std::string();
  const double pct = m.span > 0.0 ? 100.0 * m.rms / m.span : std::nan("");
  return fmt::format("{}: the model's prediction scores R^2 {:.4g} (RMS error {:.4g}, {:.3g} % of the output's span){}{}: "
                     "the model describes this record far worse than the one it was fitted on (another actuator or "
                     "condition, or other signals in these columns?), and no sign, scale or zero explains it (the best map gain x prediction + "
                     "offset leaves R^2 {:.3f})",
                     what, m.r2, m.rms, pct, train,
                     m.r2 <= 0.0 ? ", worse than the record's mean" : "", m.r2_mapped);
}

RecordDiagnosis diagnose_record(const ModelParams& params, std::span<const double> x, std::span<const double> y,
                                IndexRange range, InitialState initial, bool censor, const OutputMap& map,
                                const FitMetrics& train, double input_share, std::string_view what) {
  RecordDiagnosis d;
  d.warning = output_map_warning(map, what, train.r2, train.rms, input_share);
  d.map_named = output_map_names(map, train.r2, train.rms, input_share);
  if (!d.warning.empty())
    if (InputMap im = input_map(params, x, y, range, initial, censor, train.rms); im.found) {
      d.warning = input_map_warning(im, what);
      d.map_named = true;
      d.input_map = im;
    }
  d.sensor_warning = stuck_output_warning(x, y, range, what);
  d.input_sensor_warning = stuck_input_warning(x, y, range, what);
  d.outlier_warning = outlier_warning(x, y, range, what);
  return d;
}

EvaluationVerdict judge_evaluation(const ModelParams& params, std::span<const double> x, std::span<const double> y,
                                   IndexRange range, InitialState initial, bool censor, const OutputMap& map,
                                   const FitMetrics& metrics, const FitMetrics& train, double input_share,
                                   std::string_view what, std::string_view samples) {
  EvaluationVerdict v;
  v.diagnosis = diagnose_record(params, x, y, range, initial, censor, map, train, input_share, what);
  // without the model file's training error there is nothing to compare the record's with
  v.useless = std::isfinite(train.rms) && validation_useless(metrics, train, input_share, v.diagnosis.map_named);
  if (v.useless)
    v.useless_warning = fmt::format(
        "the evaluation is useless: the model predicts {} ({}: R^2 {:.4g}, RMS {:.4g}, {:.4g} % of span) worse than its "
        "mean (R^2 <= 0) and with more than {:g} times its training RMS error ({:.4g}; training R^2 {:.4g}, the model "
        "file's \"training\")",
        what, samples, metrics.r2, metrics.rms, metrics.rms_percent_span, kValidationRmsFactor, train.rms, train.r2);
  return v;
}

InputMap input_map(const ModelParams& params, std::span<const double> x, std::span<const double> y, IndexRange range,
                   InitialState initial, bool censor, double train_rms) {
  detail::check_record(x, y, "input_map");
  const IndexRange r = detail::check_range(range, x.size(), "input_map");
  InputMap best;
  const Limits lim = input_limits(params);
  if (!lim.bounded() || !(lim.hi > lim.lo) || r.end - r.begin < 2) return best;
  const auto score = [&](double scale, double shift) -> std::optional<FitMetrics> {
    std::vector<double> xm(x.begin(), x.end());
    for (double& v : xm) v = scale * v + shift;
    try {
      return evaluate_scored(params, xm, y, r, initial, censor);
    } catch (const Error&) {  // an input beyond the model's bound: not this map
      return std::nullopt;
    }
  };
  const auto as_is = score(1.0, 0.0);
  if (!as_is || !std::isfinite(as_is->rms)) return best;
  best.rms_as_is = as_is->rms;
  const auto [lo_it, hi_it] = std::minmax_element(x.begin() + static_cast<std::ptrdiff_t>(r.begin),
                                                  x.begin() + static_cast<std::ptrdiff_t>(r.end));
  const double lo = *lo_it, hi = *hi_it, span = lim.hi - lim.lo;
  std::vector<std::pair<double, double>> candidates;  // (scale, shift)
  // a zero: the least or the largest input moved onto the limits' (more than the coverage tolerance)
  for (const double shift : {lim.lo - lo, lim.hi - hi})
    if (std::abs(shift) > kInputCoverageTolerance * span) candidates.push_back({1.0, shift});
  // a unit: a power of ten between the spans (10^-9 .. 10^9, not 1)
  if (hi > lo) {
    const double k = std::round(std::log10(span / (hi - lo)));
    if (k != 0.0 && std::abs(k) <= 9.0) candidates.push_back({std::pow(10.0, k), 0.0});
  }
  for (const auto& [scale, shift] : candidates) {
    const auto m = score(scale, shift);
    if (!m || !std::isfinite(m->rms) || (best.found && !(m->rms < best.rms))) continue;
    const bool good = std::isfinite(train_rms) ? m->rms <= kValidationRmsFactor * train_rms
                                               : m->rms <= 0.5 * as_is->rms && m->r2 >= kMinFitR2;
    if (!good || !(m->rms < as_is->rms)) continue;
    best.found = true;
    best.scale = scale;
    best.shift = shift;
    best.rms = m->rms;
    best.r2 = m->r2;
  }
  return best;
}

std::string input_map_warning(const InputMap& m, std::string_view what) {
  if (!m.found) return {};
  const std::string map =
      m.scale != 1.0
          ? fmt::format("scaled by {:g} (another unit: kPa against MPa is a factor 1000, Pa against kPa too?)", m.scale)
          : fmt::format("shifted by {:+.4g} (another zero: absolute against gauge pressure, 0.101325 MPa or 101.3 "
                        "kPa?)",
                        m.shift);
  return fmt::format("{}: the record's input matches the model's when {}: the model's RMS error on it is then {:.4g} "
                     "(R^2 {:.4g}) against {:.4g} on the input as recorded; the input, not the output, differs from "
                     "the record the model was fitted on: convert it before fitting or evaluating",
                     what, map, m.rms, m.r2, m.rms_as_is);
}

}  // namespace hysteron
