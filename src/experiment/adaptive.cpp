// The adaptive variant's inverse model (experiment.hpp, docs/control.md "Adaptive
// inverse"): RLS with forgetting on the weights of the fitted model, projected onto the
// invertibility constraints, a guard against a worse prediction, and an exact inverse
// whose weights are updated in place. The RLS is the equations of hysteron::Rls
// (identify.hpp) with three additions that Rls does not have: the estimate itself is
// projected after each update, the covariance is bounded (no wind-up in the directions
// a tracking run does not excite), and dead-zone models are adapted through the inverse
// of their (fixed) dead zones.
#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <algorithm>
#include <cmath>

#include "../core/rls_update.hpp"
#include "detail.hpp"
#include "hysteron/error.hpp"

namespace hysteron {

void AdaptiveInverseParams::validate() const {
  if (!(lambda > 0 && lambda <= 1)) throw Error(fmt::format("adaptive inverse: lambda must be in (0, 1], got {}", lambda));
  if (!(margin >= 0) || !std::isfinite(margin))
    throw Error(fmt::format("adaptive inverse: margin must be >= 0 (0: derived), got {}", margin));
  if (delay > 100000) throw Error(fmt::format("adaptive inverse: delay must be at most 100000 samples, got {}", delay));
}

namespace {

InverseOptions inverse_options(const AdaptiveInverseParams& p) {
  p.validate();
  InverseOptions o;
  o.input_limits = p.input_limits;
  return o;
}

}  // namespace

AdaptiveInverse::AdaptiveInverse(const ModelParams& model, std::span<const double> prior_x,
                                 std::span<const double> prior_y, const AdaptiveInverseParams& params)
    : p_(params), s_([&] {
        if (!has_pi_structure(model))
          throw Error(fmt::format("adaptive inverse: {} is not a model of the PI family (no weights to adapt)",
                                  model_name(model)));
        return canonical_structure(model);
      }()),
      inverse_(model, inverse_options(params)) {
  const std::string_view name = model_name(model);
  if (!inverse_.analytical() && !s_.asymmetric)
    throw Error(fmt::format("adaptive inverse: {} is not a model of the PI family (no weights to adapt)", name));
  if (prior_x.size() != prior_y.size() || prior_x.size() < 2)
    throw Error(fmt::format("adaptive inverse: the prior record needs as many outputs as inputs, at least 2 (got {} "
                            "and {})",
                            prior_x.size(), prior_y.size()));
  const std::size_t n = s_.r.size(), m = n + 1;
  y_.assign(n, 0.0);
  theta_.assign(m, 0.0);
  theta_[0] = s_.q;
  std::copy(s_.p.begin(), s_.p.end(), theta_.begin() + 1);
  theta_fixed_ = theta_;
  theta_hat_ = theta_;
  clip_.assign(m, 0.0);
  w_.assign(m, 0.0);
  phi_.assign(m, 0.0);
  pphi_.assign(m, 0.0);

  // The dead-zone map as breakpoints (0 and every z_k, sorted) with its values there.
  if (s_.has_dead_zones) {
    zb_ = s_.z;
    zb_.push_back(0.0);
    std::sort(zb_.begin(), zb_.end());
    zb_.erase(std::unique(zb_.begin(), zb_.end()), zb_.end());
    zv_.resize(zb_.size());
    for (std::size_t k = 0; k < zb_.size(); ++k) zv_[k] = dead_zone_map(s_, zb_[k]);
    lo_slope_ = zv_.front() - dead_zone_map(s_, zb_.front() - 1.0);
    hi_slope_ = dead_zone_map(s_, zb_.back() + 1.0) - zv_.back();
  }

  // The prior: information of the record with the same forgetting, and the spans for the margin.
  Eigen::MatrixXd R = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(m), static_cast<Eigen::Index>(m));
  double ulo = INFINITY, uhi = -INFINITY, vlo = INFINITY, vhi = -INFINITY;
  for (std::size_t k = 0; k < prior_x.size(); ++k)
    if (!std::isfinite(prior_x[k]) || !std::isfinite(prior_y[k]))
      throw Error(fmt::format("adaptive inverse: prior record sample {} is not finite", k));
  if (prior_x.size() <= p_.delay + 1)
    throw Error(fmt::format("adaptive inverse: the prior record ({} samples) is not longer than the delay + 1 ({})",
                            prior_x.size(), p_.delay + 1));
  for (std::size_t k = p_.delay; k < prior_x.size(); ++k) {
    regressor(prior_x[k - p_.delay]);
    const Eigen::Map<const Eigen::VectorXd> phi(phi_.data(), static_cast<Eigen::Index>(m));
    R *= p_.lambda;
    R.noalias() += phi * phi.transpose();
    ulo = std::min(ulo, phi_[0]);
    uhi = std::max(uhi, phi_[0]);
    const double v = dz_inverse(s_.model_output(prior_y[k]));
    vlo = std::min(vlo, v);
    vhi = std::max(vhi, v);
  }
  std::fill(y_.begin(), y_.end(), 0.0);  // the tracking run starts from rest, as the rig
  xs_.assign(p_.delay + 1, 0.0);
  const double delta = 1e-9 * std::max(R.trace() / static_cast<double>(m), 1e-300);
  R += delta * Eigen::MatrixXd::Identity(static_cast<Eigen::Index>(m), static_cast<Eigen::Index>(m));
  const Eigen::MatrixXd P0 = R.ldlt().solve(Eigen::MatrixXd::Identity(static_cast<Eigen::Index>(m), static_cast<Eigen::Index>(m)));
  if (!P0.allFinite()) throw Error("adaptive inverse: the prior record's information matrix cannot be inverted");
  P_.assign(m * m, 0.0);
  R_.assign(m * m, 0.0);
  for (std::size_t i = 0; i < m; ++i)
    for (std::size_t j = 0; j < m; ++j) {
      const auto a = static_cast<Eigen::Index>(i), b = static_cast<Eigen::Index>(j);
      P_[i * m + j] = 0.5 * (P0(a, b) + P0(b, a));
      R_[i * m + j] = R(a, b);
    }
  trace0_ = P0.trace();
  P0_ = P_;
  R0_ = R_;

  // Margin: the fit's minimum-slope rule on the prior record, lowered to what the fitted
  // weights satisfy themselves (they must be feasible: the variant starts from them).
  double fitted_min = theta_[0];
  if (s_.asymmetric) {
    for (std::size_t i = 0; i < n; ++i)
      if (!(s_.p[i] >= 0)) throw Error(fmt::format("adaptive inverse: {} has a negative weight p[{}]", name, i));
  } else {
    double sum = theta_[0];
    for (std::size_t i = 0; i < n; ++i) fitted_min = std::min(fitted_min, sum += s_.p[i]);
  }
  if (!(fitted_min > 0)) throw Error(fmt::format("adaptive inverse: {} is not invertible (a cumulative slope <= 0)", name));
  const double rule = uhi > ulo && vhi > vlo ? FitOptions{}.min_slope * (vhi - vlo) / (uhi - ulo) : fitted_min;
  margin_ = p_.margin > 0 ? std::min(p_.margin, fitted_min) : std::min(rule, fitted_min);
}

double AdaptiveInverse::regressor(double x) noexcept {
  const double xm = s_.to_model(x);
  const double ua = envelope_value<double>(s_.asc_kind, s_.asc_c.data(), xm);
  const std::size_t n = y_.size();
  if (s_.asymmetric) {
    const double ud = envelope_value<double>(s_.desc_kind, s_.desc_c.data(), xm);
    phi_[0] = 0.5 * (ua + ud);
    for (std::size_t i = 0; i < n; ++i) phi_[i + 1] = y_[i] = ops::asymmetric_play<double>(ua, ud, s_.r[i], y_[i]);
  } else {
    phi_[0] = ua;
    for (std::size_t i = 0; i < n; ++i) phi_[i + 1] = y_[i] = ops::generalized_play<double>(ua, s_.r[i], y_[i]);
  }
  return 0.0;
}

double AdaptiveInverse::dz(double v) const noexcept { return s_.has_dead_zones ? dead_zone_map(s_, v) : v; }

double AdaptiveInverse::dz_inverse(double y) const noexcept {
  if (!s_.has_dead_zones) return y;
  if (y <= zv_.front()) return zb_.front() + (y - zv_.front()) / lo_slope_;
  if (y >= zv_.back()) return zb_.back() + (y - zv_.back()) / hi_slope_;
  std::size_t k = 0;
  while (k + 2 < zv_.size() && zv_[k + 1] <= y) ++k;
  return zb_[k] + (y - zv_[k]) * (zb_[k + 1] - zb_[k]) / (zv_[k + 1] - zv_[k]);
}

double AdaptiveInverse::min_constraint() const noexcept {
  double c = theta_[0];
  if (s_.asymmetric) {
    for (std::size_t i = 1; i < theta_.size(); ++i) c = std::min(c, theta_[i] + margin_);
  } else {
    double sum = theta_[0];
    for (std::size_t i = 1; i < theta_.size(); ++i) c = std::min(c, sum += theta_[i]);
  }
  return c;
}

// Distance (theta - theta_hat)^T R (theta - theta_hat) in the information metric; w = R (theta - theta_hat).
double AdaptiveInverse::distance(const std::vector<double>& theta) noexcept {
  const std::size_t m = theta.size();
  double d = 0.0;
  for (std::size_t i = 0; i < m; ++i) {
    double a = 0.0;
    for (std::size_t j = 0; j < m; ++j) a += R_[i * m + j] * (theta[j] - theta_hat_[j]);
    w_[i] = a;
    d += (theta[i] - theta_hat_[i]) * a;
  }
  return d;
}

// theta_ <- the projection of theta_hat_ onto the constraints in the information metric R
// (the constrained least-squares weights of the same data): feasible start (the Euclidean clip
// of theta_hat_, or the last projection if it is closer), then sweeps of exact coordinate
// minimisation along the constraints' own coordinates (cumulative slopes s_i; mpi-asym: the
// weights), each clipped at its bound. Every iterate is feasible.
void AdaptiveInverse::project() noexcept {
  const std::size_t m = theta_.size();
  // Euclidean clip of theta_hat_ (in the constraints' coordinates).
  bool feasible = true;
  if (s_.asymmetric) {
    for (std::size_t i = 0; i < m; ++i) {
      const double lb = i == 0 ? margin_ : 0.0;
      clip_[i] = std::max(theta_hat_[i], lb);
      feasible = feasible && clip_[i] == theta_hat_[i];
    }
  } else {
    double s_old = 0.0, s_new_prev = 0.0;
    for (std::size_t i = 0; i < m; ++i) {
      s_old += theta_hat_[i];
      const double s_new = std::max(s_old, margin_);
      feasible = feasible && s_new == s_old;
      clip_[i] = s_new - s_new_prev;
      s_new_prev = s_new;
    }
  }
  if (feasible) {
    theta_ = theta_hat_;
    return;
  }
  ++n_.projected;
  const double d_clip = distance(clip_);
  const double d_last = distance(theta_);  // leaves w_ for theta_
  if (d_clip < d_last) {
    theta_ = clip_;
    distance(theta_);
  }
  for (int sweep = 0; sweep < kSweeps; ++sweep) {
    if (s_.asymmetric) {
      for (std::size_t i = 0; i < m; ++i) {
        const double curv = R_[i * m + i];
        if (!(curv > 0)) continue;
        const double lb = i == 0 ? margin_ : 0.0;
        const double step = std::max(-w_[i] / curv, lb - theta_[i]);
        if (step == 0.0) continue;
        theta_[i] += step;
        for (std::size_t j = 0; j < m; ++j) w_[j] += step * R_[j * m + i];
      }
    } else {
      // Direction of s_i: +1 on theta_i, -1 on theta_{i+1} (the later slopes unchanged).
      double s_i = 0.0;
      for (std::size_t i = 0; i < m; ++i) {
        s_i += theta_[i];
        const bool last = i + 1 == m;
        const double g = last ? w_[i] : w_[i] - w_[i + 1];
        const double curv = last ? R_[i * m + i] : R_[i * m + i] - 2 * R_[i * m + i + 1] + R_[(i + 1) * m + i + 1];
        if (!(curv > 0)) continue;
        const double step = std::max(-g / curv, margin_ - s_i);
        if (step == 0.0) continue;
        theta_[i] += step;
        s_i += step;
        if (!last) theta_[i + 1] -= step;
        for (std::size_t j = 0; j < m; ++j) w_[j] += step * (R_[j * m + i] - (last ? 0.0 : R_[j * m + i + 1]));
      }
    }
  }
}

void AdaptiveInverse::update(double x, double y) noexcept {
  if (!std::isfinite(x) || !std::isfinite(y)) {
    ++faults_;
    return;
  }
  // The input `delay` samples ago drives the operators paired with this output.
  xs_[xi_] = x;
  xi_ = (xi_ + 1) % xs_.size();
  if (xn_ < xs_.size()) ++xn_;
  if (xn_ < xs_.size()) return;  // fewer than delay + 1 inputs yet
  regressor(xs_[xi_]);           // the oldest held input
  if (p_.frozen) return;  // the operators follow the input; the weights stay the fitted ones
  const std::size_t m = theta_.size();
  const double ym = s_.model_output(y);
  const double t = dz_inverse(ym);
  double va = 0.0, vf = 0.0, vh = 0.0;
  for (std::size_t i = 0; i < m; ++i) {
    va += theta_[i] * phi_[i];
    vf += theta_fixed_[i] * phi_[i];
    vh += theta_hat_[i] * phi_[i];
  }
  // Guard statistics: a-priori errors of the adapted (projected) and the fitted weights.
  const double g = s_.units.output_gain;  // errors in raw output units
  const double ea = g * (ym - dz(va)), ef = g * (ym - dz(vf));
  j_adapted_ = p_.lambda * j_adapted_ + ea * ea;
  j_fixed_ = p_.lambda * j_fixed_ + ef * ef;
  // RLS with forgetting (the unconstrained estimate theta_hat_), with its information R = P^-1.
  const double e = t - vh;
  const detail::RlsMatrices cov{P_.data(), R_.data(), P0_.data(), R0_.data(), pphi_.data(), m, trace0_};
  double gain = 0.0;
  const auto outcome = std::isfinite(e) ? detail::rls_covariance_step(cov, phi_.data(), p_.lambda, gain)
                                        : detail::RlsOutcome::skipped;
  if (outcome == detail::RlsOutcome::bounded) ++n_.bounded;
  if (outcome == detail::RlsOutcome::reset) {
    ++n_.resets;
    ++faults_;
  }
  if (outcome == detail::RlsOutcome::skipped) {
    ++faults_;
  } else {
    for (std::size_t i = 0; i < m; ++i) theta_hat_[i] += pphi_[i] * gain * e;
    project();
    ++n_.updates;
  }
  if (p_.commit_every_update) commit();
  else if (!adapted_) ++n_.fallback;
}

void AdaptiveInverse::commit() noexcept {
  // Guard: the adapted weights only while they predict at least as well as the fitted ones.
  const bool use = j_adapted_ <= j_fixed_;
  const bool switched = use != adapted_;
  if (switched) ++n_.switches;
  adapted_ = use;
  ++n_.commits;
  if (p_.commit_every_update && !adapted_) ++n_.fallback;
  if (!adapted_ && !switched) return;  // the inverse has the fitted weights already
  const std::span<const double> w = weights_in_use();
  if (!inverse_.set_weights(w[0], w.subspan(1))) {
    ++n_.rejected;
    adapted_ = false;
    inverse_.set_weights(theta_fixed_[0], std::span<const double>(theta_fixed_).subspan(1));
  }
}

}  // namespace hysteron
