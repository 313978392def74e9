// Loops tuned from the identification run of the rig at hand (detail.hpp, docs/control.md).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>

#include "detail.hpp"
#include "hysteron/error.hpp"

namespace hysteron::experiment {

namespace {

// ys lagged by tau (backward Euler, a = tc / (tau + tc)) into z.
void lag(const std::vector<double>& ys, double a, std::vector<double>& z) {
  double zk = ys.front();
  for (std::size_t k = 0; k < ys.size(); ++k) {
    zk += a * (ys[k] - zk);
    z[k] = zk;
  }
}

// SSE of x against z delayed by `delay` samples, from sample `from` on (z[0] before z's
// start). Four partial sums: a single one serializes on the add's latency, and this is the
// inner loop of identify_dynamics' grid (about 4000 calls per experiment).
double delayed_sse(const std::vector<double>& z, const std::vector<double>& x, std::size_t delay, std::size_t from) {
  double sse = 0.0;
  std::size_t k = from;
  for (; k < x.size() && k < delay; ++k) {
    const double d = x[k] - z[0];
    sse += d * d;
  }
  if (k >= x.size()) return sse;
  const double* xs = x.data() + k;
  const double* zs = z.data() + (k - delay);  // z[k - delay], k >= delay here
  const std::size_t n = x.size() - k;
  double a0 = 0.0, a1 = 0.0, a2 = 0.0, a3 = 0.0;
  std::size_t i = 0;
  for (; i + 4 <= n; i += 4) {
    const double d0 = xs[i] - zs[i], d1 = xs[i + 1] - zs[i + 1], d2 = xs[i + 2] - zs[i + 2], d3 = xs[i + 3] - zs[i + 3];
    a0 += d0 * d0, a1 += d1 * d1, a2 += d2 * d2, a3 += d3 * d3;
  }
  for (; i < n; ++i) {
    const double d = xs[i] - zs[i];
    a0 += d * d;
  }
  return sse + ((a0 + a1) + (a2 + a3));
}

// Upward crossings of `level` by y[from..) as a Schmitt trigger with the relay's own hysteresis
// counts them: armed once y was below level - eps, a crossing of the level counts when y then
// reaches level + eps before it falls below level - eps again (the last crossing before that
// is the one recorded). Counting every raw crossing, noise and the valves' PWM ripple around
// the level counted one cycle several times (182 "cycles" in 1 s of an oscillation with a
// 20 ms period on a noisy pressure sensor). Without noise every crossing of the level counts.
std::vector<std::size_t> upward_crossings(const std::vector<double>& y, std::size_t from, double level, double eps) {
  std::vector<std::size_t> ups;
  bool armed = false;
  std::size_t candidate = 0;
  bool has_candidate = false;
  for (std::size_t i = from; i < y.size(); ++i) {
    if (y[i] < level - eps) armed = true, has_candidate = false;
    if (!armed) continue;
    if (i > from && y[i - 1] < level && y[i] >= level) candidate = i, has_candidate = true;
    if (has_candidate && y[i] >= level + eps) {
      ups.push_back(candidate);
      armed = has_candidate = false;
    }
  }
  return ups;
}

// The limit cycle of a relay test in y[from..) around `level` (docs/control.md, section 1):
// amplitude a = half the peak-to-peak, the cycles counted by upward_crossings, their mean
// period T_u [s] and the describing function's ultimate gain K_u = 4 h / (pi sqrt(a^2 - eps^2))
// for a relay of amplitude h and hysteresis eps. `oscillated`: at least 3 crossings and
// a > eps (else T_u and K_u are 0).
struct RelayCycle {
  double amplitude = 0.0;
  std::size_t crossings = 0;
  double period_s = 0.0, ultimate_gain = 0.0;
  bool oscillated = false;
};

RelayCycle relay_cycle(const std::vector<double>& y, std::size_t from, double level, double eps, double h, double tc) {
  RelayCycle r;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (std::size_t i = from; i < y.size(); ++i) lo = std::min(lo, y[i]), hi = std::max(hi, y[i]);
  const std::vector<std::size_t> ups = upward_crossings(y, from, level, eps);
  r.amplitude = 0.5 * (hi - lo);
  r.crossings = ups.size();
  r.oscillated = ups.size() >= 3 && r.amplitude > eps;
  if (!r.oscillated) return r;
  r.period_s = static_cast<double>(ups.back() - ups.front()) * tc / static_cast<double>(ups.size() - 1);
  r.ultimate_gain = 4.0 * h / (std::numbers::pi * std::sqrt(r.amplitude * r.amplitude - eps * eps));
  return r;
}

}  // namespace

// sigma^2 = E[(y_k - y_{k-1})^2] / 2 for white noise (detail.hpp).
double first_difference_sigma(const std::vector<double>& y, std::size_t from, std::size_t to) {
  double s2 = 0.0;
  for (std::size_t i = from + 1; i < to; ++i) s2 += (y[i] - y[i - 1]) * (y[i] - y[i - 1]);
  return std::sqrt(s2 / (2.0 * static_cast<double>(to - from - 1)));
}

RigDynamics identify_dynamics(const ModelParams& model, const IdentificationRun& r, double tc, std::size_t& lead) {
  const std::vector<double>& pc = r.pressure_command_mpa;  // [MPa]
  const std::vector<double>& xm = r.contraction_mm;        // [mm]
  const std::vector<double> ys = simulate_record(model, pc);  // [mm]; rate-independent: shifts commute
  const auto max_delay = static_cast<std::size_t>(std::lround(kMaxDynamicsDelay / tc));
  const std::size_t from = std::min(max_delay, xm.size() / 2);
  std::vector<double> z(ys.size());
  auto a_of = [tc](double tau) { return tc / (tau + tc); };

  // pure delay (tau = 0): the feedforward's preview, every sample
  double best = std::numeric_limits<double>::infinity();
  lead = 0;
  for (std::size_t d = 0; d <= max_delay; ++d) {
    const double sse = delayed_sse(ys, xm, d, from);
    if (sse < best) best = sse, lead = d;
  }
  // (theta, tau): coarse grid of 5 ms, then every sample around the best (1 ms at 1 ms; a faster
  // loop resolves both finer, e.g. lag 7.5 ms at 0.5 ms for 9 ms at 1 ms on mpi-pwm --seed 1)
  const auto coarse = std::max<std::size_t>(1, static_cast<std::size_t>(std::lround(0.005 / tc)));
  std::size_t bd = 0, bt = 0;  // delay and tau in samples
  best = std::numeric_limits<double>::infinity();
  auto scan = [&](std::size_t d0, std::size_t d1, std::size_t t0, std::size_t t1, std::size_t step) {
    for (std::size_t ti = t0; ti <= t1; ti += step) {
      lag(ys, a_of(static_cast<double>(ti) * tc), z);
      for (std::size_t d = d0; d <= d1; d += step) {
        const double sse = delayed_sse(z, xm, d, from);
        if (sse < best) best = sse, bd = d, bt = ti;
      }
    }
  };
  scan(0, max_delay, 0, max_delay, coarse);
  scan(bd > coarse ? bd - coarse : 0, std::min(max_delay, bd + coarse), bt > coarse ? bt - coarse : 0,
       std::min(max_delay, bt + coarse), 1);

  RigDynamics dyn;
  dyn.dead_time_s = static_cast<double>(bd) * tc;
  dyn.lag_s = static_cast<double>(bt) * tc;
  dyn.rms_mm = std::sqrt(best / static_cast<double>(xm.size() - from));
  // K: least-squares slope of contraction on commanded pressure [m/MPa]
  const auto n = static_cast<double>(pc.size());
  double sp = 0, sx = 0, spp = 0, spx = 0;
  for (std::size_t i = 0; i < pc.size(); ++i) {
    sp += pc[i], sx += xm[i], spp += pc[i] * pc[i], spx += pc[i] * xm[i];
  }
  dyn.gain_m_per_mpa = (n * spx - sp * sx) / (n * spp - sp * sp) * 1e-3;
  if (!(dyn.gain_m_per_mpa > 0.0) || !std::isfinite(dyn.rms_mm))
    throw Error(fmt::format("experiment: cannot identify the rig's dynamics (slope {} m/MPa)", dyn.gain_m_per_mpa));
  return dyn;
}

std::string dynamics_bound_note(const RigDynamics& d, double lead_s, double tc) {
  const double bound = static_cast<double>(std::lround(kMaxDynamicsDelay / tc)) * tc;
  std::string on;
  const auto add = [&](const char* what, double s) {
    if (s >= bound - 0.5 * tc) on += fmt::format("{}{} {:.0f} ms", on.empty() ? "" : ", ", what, s * 1e3);
  };
  add("dead time", d.dead_time_s);
  add("lag", d.lag_s);
  add("the feedforward's lead", lead_s);
  if (on.empty()) return {};
  return fmt::format(
      "the rig's dynamics fitted on the identification run sit on the search's bound of {:.0f} ms ({}): the rig "
      "responds more slowly than that bound resolves (a long dead time or lag), or its contraction does not follow "
      "the pressure as a lag does (a load that sticks or does not return); the gains, the lead and the learning design "
      "built on them are suspect (docs/control.md, section 1)",
      bound * 1e3, on);
}

PidParams simc_pid(const RigDynamics& d, double tc, double out_min, double out_max) {
  const double theta = std::max(d.dead_time_s, tc);  // at least one sample of delay
  const double tau = std::max(d.lag_s, tc);
  const double tau_c = theta;                        // "tight" SIMC
  PidParams p;
  p.sample_time = tc;
  p.kp = tau / (d.gain_m_per_mpa * (tau_c + theta));
  const double ti = std::min(tau, 4.0 * (tau_c + theta));
  p.ki = p.kp / ti;
  p.kd = 0.0;
  p.out_min = out_min;
  p.out_max = out_max;
  return p;
}

namespace {

// G (the FOPDT by backward Euler, times the mode at s = i w / tc), the integral and the
// derivative term of the PID, at w [rad/sample].
struct LoopTerms {
  std::complex<double> G, I, D;
};

LoopTerms loop_terms(const RigDynamics& d, const PidParams& pid, double tc, double w) {
  using C = std::complex<double>;
  const C zi = std::polar(1.0, -w);  // z^-1
  const double a = tc / (d.lag_s + tc);
  const auto delay = static_cast<double>(std::lround(d.dead_time_s / tc));
  C G = std::polar(1.0, -w * delay) * a / (1.0 - (1.0 - a) * zi);
  if (d.mode_frequency_hz > 0.0) {  // continuous mode at s = i w / tc (w << pi here)
    const double wn = 2.0 * std::numbers::pi * d.mode_frequency_hz, s_im = w / tc;
    G *= wn * wn / C(wn * wn - s_im * s_im, 2.0 * d.mode_damping * wn * s_im);
  }
  const C I = pid.ki * tc / (1.0 - zi);
  const double tf = pid.derivative_filter;
  const C D = pid.kd / (tf + tc) * (1.0 - zi) / (1.0 - tf / (tf + tc) * zi);
  return {G, I, D};
}

}  // namespace

std::complex<double> closed_loop(const RigDynamics& d, const PidParams& pid, std::size_t lead, double tc, double w) {
  const auto [G, I, D] = loop_terms(d, pid, tc, w);
  const double K = d.gain_m_per_mpa;
  const std::complex<double> lead_z = std::polar(1.0, w * static_cast<double>(lead));
  return G * (lead_z + K * (pid.kp + I)) / (1.0 + G * K * (pid.kp + I + D));
}

LoopPeaks loop_peaks(const RigDynamics& d, const PidParams& pid, double tc) {
  // 600 log-spaced frequencies from 0.05 Hz to a quarter of the sampling rate
  constexpr int kPoints = 600;
  const double w_lo = 2.0 * std::numbers::pi * 0.05 * tc, w_hi = 0.5 * std::numbers::pi;
  LoopPeaks peaks;
  for (int l = 0; l < kPoints; ++l) {
    const double w = w_lo * std::pow(w_hi / w_lo, static_cast<double>(l) / (kPoints - 1));
    const auto [G, I, D] = loop_terms(d, pid, tc, w);
    const std::complex<double> L = G * d.gain_m_per_mpa * (pid.kp + I + D);
    peaks.sensitivity = std::max(peaks.sensitivity, std::abs(1.0 / (1.0 + L)));
    peaks.complementary = std::max(peaks.complementary, std::abs(L / (1.0 + L)));
  }
  return peaks;
}

std::vector<RigDynamics> learning_neighbours(const RigDynamics& d, Neighbours which) {
  std::vector<RigDynamics> out;
  for (bool mode : {true, false})
    for (double ft : {1.0, 1.5})
      for (double fl : {0.67, 1.0, 1.5})
        for (double fk : {0.67, 1.0, 1.5}) {
          if (mode && d.mode_frequency_hz == 0.0) continue;
          if (!mode && which == Neighbours::with_mode && d.mode_frequency_hz > 0.0) continue;
          RigDynamics dv = d;
          if (!mode) dv.mode_frequency_hz = dv.mode_damping = 0.0;
          dv.dead_time_s *= ft;
          dv.lag_s *= fl;
          dv.gain_m_per_mpa *= fk;
          // A neighbour's mode is fitted through the relay's point again, as the identified one
          // is: every neighbour with a mode agrees with what the relay measured at w_u. One whose
          // FOPDT alone explains the point has none: it is its twin without a mode.
          if (mode) {
            fit_load_mode(dv);
            if (dv.mode_frequency_hz == 0.0) continue;
          }
          out.push_back(dv);
        }
  return out;
}

namespace {
// The learning design's frequency grid [rad/sample]: kLearningGrid points from the period's
// fundamental to Nyquist, log-spaced.
constexpr std::size_t kLearningGrid = 600;
std::vector<double> learning_grid(std::size_t period) {
  std::vector<double> w(kLearningGrid);
  const double w0 = 2.0 * std::numbers::pi / static_cast<double>(period);
  for (std::size_t l = 0; l < kLearningGrid; ++l)
    w[l] = w0 * std::pow(std::numbers::pi / w0, static_cast<double>(l) / (kLearningGrid - 1));
  return w;
}
}  // namespace

double learning_growth_limit(const RigDynamics& d, const PidParams& pid, std::size_t lead, const LearningParams& p,
                             double tc) {
  const std::vector<double> w = learning_grid(p.period);
  std::vector<std::complex<double>> T(w.size());
  for (std::size_t l = 0; l < w.size(); ++l) T[l] = closed_loop(d, pid, lead, tc, w[l]);
  // {L : |Q| |1 - L z| < 1} is an interval at each frequency, so their intersection is one too:
  // the largest gain tried that contracts bounds every gain between it and the design's
  double limit = p.gain;
  for (double gain : kLearningGains) {
    if (gain <= limit) continue;
    LearningParams q = p;
    q.gain = gain;
    if (learning_contraction(q, w, T) < 1.0) limit = gain;
  }
  return limit;
}

LearningParams design_learning(const RigDynamics& d, const PidParams& pid, std::size_t lead, std::size_t period,
                               double tc, double& contraction, Neighbours which, FilterWindow window) {
  constexpr std::size_t kGrid = kLearningGrid;
  const std::vector<double> w0s = learning_grid(period);
  // robust: one contraction bound over the identified loop and its neighbours
  std::vector<double> w;
  std::vector<std::complex<double>> T;
  for (const RigDynamics& dv : learning_neighbours(d, which))
    for (std::size_t l = 0; l < kGrid; ++l) {
      w.push_back(w0s[l]);
      T.push_back(closed_loop(dv, pid, lead, tc, w0s[l]));
    }
  LearningParams best;
  best.period = period;
  best.gain = 0.5;
  best.lookahead = lead;
  contraction = std::numeric_limits<double>::infinity();
  const std::size_t budget = period > lead + 2 ? period - lead - 2 : 0;  // lead + d + 2h (or 2r) < period
  const std::size_t max_shift = std::min<std::size_t>(budget / 2, static_cast<std::size_t>(std::lround(0.5 / tc)));
  bool found = false;
  // log cos^2(w/2) per grid point: |Q(w)| = exp(h * lc[l])
  std::vector<double> lc(w.size()), worst(kGrid);
  for (std::size_t l = 0; l < w.size(); ++l) {
    const double c = std::cos(0.5 * w[l]);
    lc[l] = std::log(c * c);
  }
  // |Q(w_l)| = exp(h lc[l]) on the grid, computed once per half-width h tried
  std::map<std::size_t, std::vector<double>> q_cache;
  auto q_of = [&](std::size_t h) -> const std::vector<double>& {
    auto [it, fresh] = q_cache.try_emplace(h);
    if (fresh) {
      it->second.resize(kGrid);
      for (std::size_t l = 0; l < kGrid; ++l) it->second[l] = std::exp(static_cast<double>(h) * lc[l]);
    }
    return it->second;
  };
  const auto shift_step = std::max<std::size_t>(1, static_cast<std::size_t>(std::lround(0.002 / tc)));
  // The learning band ends at the position loop's ultimate frequency w_u = 2 pi tc / T_u (its
  // relay test: the measured -180 degree point, above which the identified model is least
  // trusted, and the hysteresis' stick at reversals is not in it): |Q(w_u)| <= 1/sqrt(2),
  // i.e. h >= ln 2 / (2 (-ln cos^2(w_u / 2))). docs/control.md, section 3.
  std::size_t h_floor = 0;
  if (d.position_relay_period_s > 0.0) {
    const double wu = 2.0 * std::numbers::pi * tc / d.position_relay_period_s, cu = std::cos(0.5 * wu);
    if (wu < std::numbers::pi) h_floor = static_cast<std::size_t>(std::ceil(std::log(2.0) / (-2.0 * std::log(cu * cu))));
  }
  // e^{i w d} for every grid point, advanced by e^{i w shift_step} per shift (recomputed
  // exactly every 64 shifts, so rounding cannot accumulate)
  std::vector<std::complex<double>> rot(w.size()), step(w.size());
  for (std::size_t l = 0; l < w.size(); ++l) step[l] = std::polar(1.0, w[l] * static_cast<double>(shift_step));
  // The largest gain of kLearningGains for which some (shift, width) contracts. A smaller L
  // asks less of the model: |1 - L e^{iwd} T| < 1 needs Re(e^{iwd} T) > L |T|^2 / 2, so on a
  // rig whose loop rings (a lightly damped mode, a long dead time) 0.1 or 0.05 may contract
  // where 0.2 does not. Where T ~ 1 (low frequencies) the error falls by a factor of about
  // 1 - L per period (10 periods of L = 0.05: to about 0.6), so smaller gains are not tried.
  // the least bound seen, for the message where none is below 0.98
  double least = std::numeric_limits<double>::infinity(), least_gain = 0.0;
  std::size_t least_shift = 0, least_h = 0;
  // the window that must fit: the filter's 2h + 1 taps counted at kLearningWindowPeriod (2h T_s / 1 ms
  // samples of this loop: the same filter in seconds at every rate up to kMaxControlPeriod; at 20 ms the
  // floor h = 6 took 247 of a period's 244 samples), or the 2 reach + 1 the update sums
  const double per_tap = tc / kLearningWindowPeriod;  // 1 at 1 ms, exactly
  const auto window_of = [window, per_tap](std::size_t h) {
    return window == FilterWindow::whole ? 2.0 * static_cast<double>(h) * per_tap
                                         : 2.0 * static_cast<double>(binomial_reach(h));
  };
  const auto fits = [window_of, budget](std::size_t shift, std::size_t h) {
    return h <= kMaxLearningHalfWidth && static_cast<double>(shift) + window_of(h) <= static_cast<double>(budget);
  };
  // the largest half-width whose whole window fits after `shift` (the summed taps: as many as the period)
  const auto widest_fit = [window, per_tap, budget](std::size_t shift) {
    const double room = static_cast<double>(budget - shift) / 2.0;
    return static_cast<std::size_t>(window == FilterWindow::whole ? std::floor(room / per_tap) : std::floor(room));
  };
  for (double gain : kLearningGains) {
    if (found) break;
    best.gain = gain;
    std::size_t advanced = 0;
    for (std::size_t shift = 0; shift <= max_shift; shift += shift_step, ++advanced) {
      for (std::size_t l = 0; l < w.size(); ++l)
        rot[l] = advanced % 64 == 0 ? std::polar(1.0, w[l] * static_cast<double>(shift)) : rot[l] * step[l];
      // worst |1 - L e^{i w d} T| over the models, per frequency (the grid repeats per model)
      std::fill(worst.begin(), worst.end(), 0.0);
      for (std::size_t l = 0; l < w.size(); ++l) {
        const std::complex<double> v = 1.0 - gain * rot[l] * T[l];
        const double a = std::sqrt(std::norm(v));
        worst[l % kGrid] = std::max(worst[l % kGrid], std::isfinite(a) ? a : 1e300);
      }
      // smallest half-width (widest band) that contracts with a 2 % margin
      const std::size_t h0 = std::min(h_floor, widest_fit(shift));  // the floor, or as near as the period allows
      for (std::size_t h = h0; fits(shift, h); h = h < 4 ? h + 1 : h + h / 4) {
        if (found && h > best.half_width) break;
        const std::vector<double>& q = q_of(h);
        double rho = 0.0;
        for (std::size_t l = 0; l < kGrid; ++l) rho = std::max(rho, q[l] * worst[l]);
        if (rho < least) least = rho, least_gain = gain, least_shift = shift, least_h = h;
        if (rho < 0.98) {
          if (!found || h < best.half_width || rho < contraction) {
            best.lead = shift;
            best.half_width = h;
            contraction = rho;
            found = true;
          }
          break;
        }
      }
    }
  }
  if (found) contraction = learning_contraction(best, w, T);  // the bound as the library computes it
  if (!found)
    throw Error(fmt::format("no learning filter contracts on the identified loop and its neighbours "
                            "(theta = {:.3f} s, tau = {:.3f} s, mode {:.2f} Hz, damping {:.2f}; period {} samples; {})",
                            d.dead_time_s, d.lag_s, d.mode_frequency_hz, d.mode_damping, period,
                            std::isfinite(least)
                                ? fmt::format("the least bound found is rho = {:.4f} at L = {:g}, lead {} samples, "
                                              "half-width {}; 0.98 needed", least, least_gain, least_shift, least_h)
                                : std::string("no filter fits in the period")));
  return best;
}

}  // namespace hysteron::experiment

namespace hysteron::experiment {

namespace {

// One run of the valves' pressure relay around p0 [MPa] (relay_test): the limit cycle of its
// last second, the highest pressure measured over the whole run (`top`) and the relay's
// hysteresis eps.
struct PressureRelayRun {
  RelayCycle cycle;
  double top = 0.0, eps = 0.0;
};

PressureRelayRun pressure_relay_run(const PamRigParams& rp, std::uint64_t seed, double tc, double p0,
                                    double h = 0.5 /* relay amplitude [duty] */) {
  const auto quiet = static_cast<std::size_t>(std::lround(0.2 / tc));
  const auto max_fill = static_cast<std::size_t>(std::lround(2.0 / tc));
  const auto relay_n = static_cast<std::size_t>(std::lround(1.8 / tc));
  PamRig rig(rp, seed);
  rig.reset();
  std::vector<double> p;
  p.reserve(max_fill + quiet + relay_n);
  double eps = 0.0;
  bool up = true;
  // 1. fill to p0 (the reading can clip while vented: a sensor offset below zero reads 0 there),
  // 2. valves closed for `quiet`: the relay's hysteresis 3 sigma of the sensor's noise
  //    (first_difference_sigma: the slow pressure change as the load settles adds little),
  // 3. the relay around p0.
  std::size_t k = 0, filled = 0, relay_from = 0;
  auto control = [&](const RigOutputs& o) {
    const double pm = o.pressure_measured * 1e-6;
    p.push_back(pm);
    double duty = 0.0;
    if (filled == 0) {
      if (pm >= p0 || k + 1 >= max_fill) filled = k + 1;
      else duty = h;
    }
    if (filled > 0 && relay_from == 0 && k + 1 >= filled + quiet) {
      eps = 3.0 * first_difference_sigma(p, filled, k + 1);
      relay_from = k + 1;
    }
    if (relay_from > 0 && k >= relay_from) {
      if (up && pm > p0 + eps) up = false;
      if (!up && pm < p0 - eps) up = true;
      duty = up ? h : -h;
    }
    ++k;
    return valves(duty, p0);
  };
  while (filled == 0) rig.run(tc, tc, control);  // one control period at a time until filled
  rig.run(static_cast<double>(quiet + relay_n) * tc, tc, control);
  PressureRelayRun r;
  // the last second: amplitude and mean period between upward crossings of p0
  r.cycle = relay_cycle(p, p.size() - static_cast<std::size_t>(std::lround(1.0 / tc)), p0, eps, h, tc);
  r.top = *std::max_element(p.begin(), p.end());
  r.eps = eps;
  return r;
}

}  // namespace

double relay_decision_period(double tc, double dt) {
  if (tc >= kRelayDecisionPeriod) return tc;  // 1 ms and slower: the loop's own period
  // the test's own rig run at 1 ms where that is a whole number of the rig's steps (the
  // criterion of control_steps), so 0.3 and 0.7 ms loops get the 1 ms test too
  const double steps = kRelayDecisionPeriod / dt;
  if (dt > 0.0 && std::isfinite(steps) && steps >= 1.0 && std::abs(steps - std::round(steps)) <= 1e-9 * steps)
    return kRelayDecisionPeriod;
  const long n = std::max(1L, std::lround(kRelayDecisionPeriod / tc));  // else the whole tc nearest 1 ms
  return static_cast<double>(n) * tc;
}

void relay_test(const PamRigParams& rp, std::uint64_t seed, double loop_tc, RigDynamics& d, double p_max) {
  // the relay's own sample time (kRelayDecisionPeriod, relay_decision_period): its own rig run
  const double tc = relay_decision_period(loop_tc, rp.simulation.dt);
  // At relay_level(p_max) first. Where it did not oscillate and the highest pressure that run
  // measured is below twice its level (a supply that caps the rig at or below the level: the
  // limit cycle has no upper half), once more around half that top, the middle of the range
  // the rig reaches.
  double p0 = relay_level(p_max);  // [MPa]
  PressureRelayRun r = pressure_relay_run(rp, seed, tc, p0);
  std::string first;
  // Valves that barely filled the muscle at duty 0.5 (less than a tenth of the level in the 2 s
  // fill) do not open at that duty (a minimum pulse or an opening delay longer than half the
  // PWM period: 1.8 ms at 346 Hz reached 0.004 MPa): the relay runs again at full duty.
  double h = 0.5;
  if (!r.cycle.oscillated && r.top < 0.1 * p0) {
    const double top_half = r.top;
    h = 1.0;
    r = pressure_relay_run(rp, seed, tc, p0, h);
    first = fmt::format("; at duty +-0.5 first, where the pressure reached at most {:.4f} MPa (the valves did not "
                        "open: a minimum pulse or opening delay longer than half the PWM period?), then at +-1",
                        top_half);
  }
  if (!r.cycle.oscillated && r.top > 0.0 && 0.5 * r.top < p0 - r.eps) {
    first += fmt::format("; around {} MPa first, where the pressure reading reached at most {:.4f} MPa (the supply or the "
                         "valves cap it, or the pressure sensor's range ends there)",
                         p0, r.top);
    p0 = 0.5 * r.top;
    r = pressure_relay_run(rp, seed, tc, p0, h);
  }
  if (!r.cycle.oscillated)
    throw Error(fmt::format("experiment: the relay test of the valves' pressure loop did not oscillate around {:.4g} "
                            "MPa (amplitude {:.3g} MPa, {} crossings{})",
                            p0, r.cycle.amplitude, r.cycle.crossings, first));
  d.relay_period_s = r.cycle.period_s;
  d.relay_gain = r.cycle.ultimate_gain;
  d.relay_level_mpa = p0;
  d.relay_duty = h;
}

PidParams tyreus_luyben_pi(const RigDynamics& d, double tc) {
  PidParams p;
  p.sample_time = tc;
  p.kp = d.relay_gain / 3.2;
  p.ki = p.kp / (2.2 * d.relay_period_s);
  p.out_min = -1.0;
  p.out_max = 1.0;
  return p;
}

}  // namespace hysteron::experiment

namespace hysteron::experiment {

namespace {

// One relay run of the position loop with amplitude h [MPa] around p0 for `relay_s` seconds
// after 1.5 s at p0 (docs/control.md, section 1): the limit cycle of its last relay_s / 2;
// fills `d` where the contraction oscillated.
RelayCycle position_relay_run(const PamRigParams& rp, std::uint64_t seed, double tc, const Actuator& actuator,
                              double p0, double h, double relay_s, RigDynamics& d) {
  const auto settle = static_cast<std::size_t>(std::lround(1.5 / tc));
  const auto quiet = static_cast<std::size_t>(std::lround(0.3 / tc));
  const auto n = settle + static_cast<std::size_t>(std::lround(relay_s / tc));
  PamRig rig(rp, seed);
  rig.reset();
  std::vector<double> x;
  x.reserve(n);
  double x0 = 0.0, eps = 0.0;
  bool up = true;
  std::size_t k = 0;
  rig.run(static_cast<double>(n) * tc, tc, [&](const RigOutputs& o) {
    x.push_back(o.contraction_measured);
    if (k == settle) {  // level and noise at p0 over the last `quiet` samples (the samples'
      // spread would count the load still settling: 1.1-3.8x the sensor's sigma on the documented rigs)
      double m = 0;
      for (std::size_t i = settle - quiet; i < settle; ++i) m += x[i];
      x0 = m / static_cast<double>(quiet);
      eps = 3.0 * first_difference_sigma(x, settle - quiet, settle);
    }
    double p = p0;
    if (k >= settle) {
      const double xm = o.contraction_measured;
      if (up && xm > x0 + eps) up = false;
      if (!up && xm < x0 - eps) up = true;
      p = up ? p0 + h : p0 - h;
    }
    ++k;
    return actuator(p, o);
  });
  const RelayCycle cycle =
      relay_cycle(x, n - static_cast<std::size_t>(std::lround(0.5 * relay_s / tc)), x0, eps, h, tc);
  if (!cycle.oscillated) return cycle;
  d.position_relay_amplitude_mpa = h;
  d.position_relay_level_mpa = p0;
  d.position_relay_hysteresis_m = eps;
  d.position_relay_period_s = cycle.period_s;
  d.position_relay_gain = cycle.ultimate_gain;
  return cycle;
}

}  // namespace

void position_relay_test(const PamRigParams& rp, std::uint64_t seed, double tc,
                         const std::function<Actuator()>& make_actuator, RigDynamics& d, double p_max,
                         double top, StrokePressures stroke) {
  if (!(top > 0.0 && top <= p_max))
    throw Error(fmt::format("experiment: the position relay's top pressure {} MPa must be in (0, {}]", top, p_max));
  // [MPa]: relay_level(p_max) while the relay's first upper level is within reach, else the
  // middle of the range the rig reaches (a supply that caps the actuator)
  const double middle = relay_level(p_max);
  double p0 = middle + kPositionRelayAmplitude <= top ? middle : 0.5 * top;
  // ... and the middle of the stroke where p0's lower level would let the load down onto its
  // rest: there the contraction cannot fall below its level, or the cycle is cut at the rest
  // and the describing function's K_u is far off (65 kg: 79.5 MPa/m at 0.3 MPa, 6x the
  // nominal rig's; every loop tuned from it oscillated)
  if (stroke.mid_mpa > 0.0 && p0 - kPositionRelayAmplitude < stroke.floor_mpa) p0 = stroke.mid_mpa;
  // A relay must overcome the rig's hysteresis to make the muscle reverse: where the
  // pressure band is wider than the amplitude the contraction only creeps and does not
  // cross its level. Then the amplitude is doubled (Astrom and Hagglund adjust it to the
  // process), while p0 +- h stays within the actuator's 0..top. A slow rig (a large
  // muscle filled through small valves, a heavy load) oscillates with a period too long for
  // 3 cycles in the measured window: where the contraction did cross its level (the relay
  // switched, so it is not the hysteresis that holds it), the run is repeated twice and four
  // times as long (8, 16 s of relay, the cycle measured over the last half) before the
  // amplitude grows. Where no amplitude makes it oscillate around p0, the same is tried
  // around the middle of the stroke.
  constexpr double relay_s = 4.0;  // [s] of relay; the cycle is measured over its last half
  std::string seen;
  std::vector<double> levels{p0};
  if (stroke.mid_mpa > 0.0 && std::abs(stroke.mid_mpa - p0) > 0.5 * kPositionRelayAmplitude)
    levels.push_back(stroke.mid_mpa);
  for (const double level : levels) {
    seen += fmt::format("{}around {:.3g} MPa: ", seen.empty() ? "" : "; ", level);
    bool first = true;
    for (double h = kPositionRelayAmplitude; level - h >= 0.0 && level + h <= top; h *= 2.0) {
      for (double len = relay_s; len <= 4.0 * relay_s; len *= 2.0) {
        const RelayCycle cycle = position_relay_run(rp, seed, tc, make_actuator(), level, h, len, d);
        if (cycle.oscillated) return;
        seen += fmt::format("{}+-{:g} MPa: amplitude {:.3g} mm, {} crossings in {:g} s", first ? "" : ", ", h,
                            cycle.amplitude * 1e3, cycle.crossings, 0.5 * len);
        first = false;
        if (cycle.crossings == 0) break;  // held by the hysteresis: a larger amplitude, not a longer run
      }
    }
    if (first) seen += fmt::format("no amplitude of at least {:g} MPa fits within the actuator's range", kPositionRelayAmplitude);
  }
  throw Error(fmt::format("experiment: the relay test of the position loop did not oscillate at any amplitude "
                          "within the actuator's 0..{:.3g} MPa ({}){}",
                          top, seen,
                          stroke.mid_mpa > 0.0
                              ? fmt::format("; the identification run lifted the load off its rest only above {:.3f} MPa",
                                            stroke.floor_mpa)
                              : std::string()));
}

PidParams relay_pid(const RigDynamics& d, double tc, double out_min, double out_max, PidRule rule) {
  PidParams p;
  p.sample_time = tc;
  const bool classic = rule == PidRule::classic;
  p.kp = (classic ? 0.6 : 1.0 / 3.0) * d.position_relay_gain;
  p.ki = p.kp / (0.5 * d.position_relay_period_s);
  p.kd = p.kp * d.position_relay_period_s / (classic ? 8.0 : 3.0);
  p.derivative_filter = d.position_relay_period_s / 30.0;
  p.out_min = out_min;
  p.out_max = out_max;
  return p;
}

}  // namespace hysteron::experiment

namespace hysteron::experiment {

PidParams learning_pid(const RigDynamics& d, double tc, double p_max) {
  const PidParams rule = relay_pid(d, tc, -p_max, p_max, PidRule::some_overshoot);
  const LoopPeaks at_rule = loop_peaks(d, rule, tc);
  PidParams best = rule;
  double least = at_rule.complementary;
  for (double td : {0.5, 2.0 / 3.0}) {  // T_d = T_u / 2, 2 T_u / 3 (the rule's T_u / 3 first)
    PidParams p = rule;
    p.kd = p.kp * td * d.position_relay_period_s;
    const LoopPeaks at = loop_peaks(d, p, tc);
    // a lower complementary peak, without raising the sensitivity peak; ties: the shorter T_d
    if (at.complementary < least && at.sensitivity <= at_rule.sensitivity) least = at.complementary, best = p;
  }
  return best;
}

PidParams position_pid(const Context& c) {
  if (c.learning) {
    // The learning rule's gains come from the same relay test as the classic rule's. Where the
    // gain trial found the classic gains too high on the rig (scale < 1: the relay's K_u
    // overstates the loop's margin, e.g. where a wide hysteresis band takes up the relay's
    // swing), they are scaled down as much (docs/control.md, section 2, "The learning loop's
    // PID and the gain trial"); a scale above 1 leaves the robust rule as it is.
    PidParams p = learning_pid(c.dynamics, c.tc, c.pressure_max);
    const double s = std::min(1.0, c.gain_scale);
    p.kp *= s, p.ki *= s, p.kd *= s;
    p.guard = pid_guard(c);
    return p;
  }
  PidParams p = relay_pid(c.dynamics, c.tc, -c.pressure_max, c.pressure_max, PidRule::classic);
  p.kp *= c.gain_scale;
  p.ki *= c.gain_scale;
  p.kd *= c.gain_scale;
  p.guard = pid_guard(c);
  return p;
}

PidGuard pid_guard(const Context& c) {
  PidGuard g;
  // (a T_u under 4 control periods cannot be seen by the guard: none)
  if (c.guard_amplitude_m > 0.0 && c.dynamics.position_relay_period_s >= 4.0 * c.tc) {
    g.period = c.dynamics.position_relay_period_s;
    g.amplitude = c.guard_amplitude_m;
  }
  return g;
}

double guard_amplitude(const GainTrial& g) {
  const std::vector<double>& rms = g.shaped ? g.rms_shaped_mm : g.rms_mm;
  for (std::size_t i = 0; i < g.scales.size() && i < rms.size(); ++i)
    if (g.scales[i] == g.scale && std::isfinite(rms[i])) return 2.0 * std::numbers::sqrt2 * rms[i] * 1e-3;
  return 0.0;
}

ZvShaper zv_shaper(const RigDynamics& d, double tc) {
  ZvShaper z;
  const double zeta = d.mode_damping;
  if (!(d.mode_frequency_hz > 0.0) || !(zeta >= 0.0 && zeta < 1.0)) return z;
  const double root = std::sqrt(1.0 - zeta * zeta);
  const double wd = 2.0 * std::numbers::pi * d.mode_frequency_hz * root;
  const double K = std::exp(-zeta * std::numbers::pi / root);
  const double D = std::round(std::numbers::pi / wd / tc);
  if (!(D >= 1.0) || !(D < 1e7)) return z;
  z.a1 = 1.0 / (1.0 + K);
  z.a2 = K / (1.0 + K);
  z.delay = static_cast<std::size_t>(D);
  z.advance = static_cast<std::size_t>(std::lround(z.a2 * D));
  return z;
}

std::vector<double> shaped(const std::vector<double>& r, const ZvShaper& z) {
  if (!z.active() || r.empty()) return r;
  const auto n = static_cast<std::ptrdiff_t>(r.size());
  const auto at = [&](std::ptrdiff_t k) { return r[static_cast<std::size_t>(std::clamp<std::ptrdiff_t>(k, 0, n - 1))]; };
  const auto adv = static_cast<std::ptrdiff_t>(z.advance), D = static_cast<std::ptrdiff_t>(z.delay);
  std::vector<double> out(r.size());
  for (std::ptrdiff_t k = 0; k < n; ++k) out[static_cast<std::size_t>(k)] = z.a1 * at(k + adv) + z.a2 * at(k + adv - D);
  return out;
}

std::string pid_origin(const Context& c) {
  if (c.learning) {
    const PidParams p = learning_pid(c.dynamics, c.tc, c.pressure_max);
    const LoopPeaks at = loop_peaks(c.dynamics, p, c.tc);
    return fmt::format("a relay test, Ziegler-Nichols some overshoot with T_d = {:.3g} T_u (of 0.333, 0.5 and "
                       "0.667 T_u, the least complementary sensitivity peak of the identified feedback loop, "
                       "{:.3g}, whose sensitivity peak, {:.3g}, is at most the rule's){}",
                       p.kd / p.kp / c.dynamics.position_relay_period_s, at.complementary, at.sensitivity,
                       c.gain_scale < 1.0 ? fmt::format(", x{:.2f} as the gain trial scaled the classic rule's gains",
                                                        c.gain_scale)
                                          : std::string());
  }
  return fmt::format("a relay test, Ziegler-Nichols x{:.2f} by a gain trial", c.gain_scale);
}

bool fit_fopdt_to_relay_phase(RigDynamics& d) {
  if (d.mode_frequency_hz > 0.0 || !(d.position_relay_period_s > 0.0)) return false;
  const double wu = 2.0 * std::numbers::pi / d.position_relay_period_s;
  const double sum = d.dead_time_s + d.lag_s;  // theta + tau, kept
  auto lag_at = [&](double theta) { return wu * theta + std::atan(wu * (sum - theta)); };  // -arg F(i w_u)
  if (!(lag_at(d.dead_time_s) > std::numbers::pi)) return false;
  double lo = 0.0, hi = d.dead_time_s;  // lag_at rises with theta: lag_at(0) < pi < lag_at(hi)
  for (int i = 0; i < 100 && hi - lo > 1e-12; ++i) (lag_at(0.5 * (lo + hi)) > std::numbers::pi ? hi : lo) = 0.5 * (lo + hi);
  d.dead_time_s = 0.5 * (lo + hi);
  d.lag_s = sum - d.dead_time_s;
  return true;
}

bool fit_fopdt_through_relay_point(RigDynamics& d) {
  if (d.mode_frequency_hz > 0.0 || !(d.position_relay_gain > 0.0) || !(d.position_relay_period_s > 0.0)) return false;
  const double wu = 2.0 * std::numbers::pi / d.position_relay_period_s;
  const double kk = d.gain_m_per_mpa * d.position_relay_gain;  // |F(0)| K_u
  if (!(kk > 1.0) || !std::isfinite(kk)) return false;
  const double tau = std::sqrt(kk * kk - 1.0) / wu;                     // |F(i w_u)| = 1 / K_u
  const double theta = (std::numbers::pi - std::atan(wu * tau)) / wu;  // arg F(i w_u) = -pi
  d.dead_time_s = theta;
  d.lag_s = tau;
  return true;
}

void fit_load_mode(RigDynamics& d) {
  d.mode_frequency_hz = d.mode_damping = 0.0;
  if (!(d.position_relay_gain > 0.0) || !(d.position_relay_period_s > 0.0)) return;
  using C = std::complex<double>;
  const double wu = 2.0 * std::numbers::pi / d.position_relay_period_s;
  const C F = d.gain_m_per_mpa * std::polar(1.0, -wu * d.dead_time_s) / C(1.0, wu * d.lag_s);
  const C inv_h = -F * d.position_relay_gain;  // 1 / H(i w_u)
  const double r2 = 1.0 - inv_h.real();
  if (!(r2 > 0.0) || !(inv_h.imag() > 0.0)) return;  // the FOPDT alone explains the point
  const double r = std::sqrt(r2);
  d.mode_frequency_hz = wu / r / (2.0 * std::numbers::pi);
  d.mode_damping = inv_h.imag() / (2.0 * r);
}

}  // namespace hysteron::experiment
