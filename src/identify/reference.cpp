// The reference PI every fit is compared with (identify.hpp, reference_pi): what a
// 20-line script does with scipy's nnls, so that no model kind of hysteron is
// allowed to be worse than it without saying so.
#include <Eigen/Core>
#include <Eigen/Householder>
#include <Eigen/QR>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "detail.hpp"
#include "hysteron/error.hpp"

namespace hysteron {

PiParams reference_pi(std::span<const double> x, std::span<const double> y, IndexRange train, int num_operators) {
  detail::check_record(x, y, "reference_pi");
  const IndexRange r = detail::check_range(train, x.size(), "reference_pi: train");
  if (num_operators < 1 || num_operators > 200)
    throw Error(fmt::format("reference_pi: num_operators must be in 1..200, got {}", num_operators));
  const auto xs = x.subspan(r.begin, r.end - r.begin);
  const auto [lo, hi] = std::minmax_element(xs.begin(), xs.end());
  const double span = *hi - *lo;
  if (!(span > 0)) throw Error("reference_pi: the input is constant over the training range");
  const auto n = static_cast<std::size_t>(num_operators);
  PiParams pi;
  pi.q = 1.0;  // placeholder so that the structure is valid
  for (std::size_t i = 1; i <= n; ++i) pi.r.push_back(static_cast<double>(i) * span / (2.0 * static_cast<double>(n)));
  pi.p.assign(n, 0.0);
  // Operators relaxed at the first sample: the input origin is x[0] and the model starts virgin there.
  const double x0 = x[0];
  // The output's sign (that of the least-squares line of y on x): a decreasing record
  // is fitted as -y with a negative output gain, so the reference is sign-equivariant.
  const double sign = detail::straight_line(x, y, r).slope < 0 ? -1.0 : 1.0;
  // Columns [x_m, -x_m, y_1..y_n] with non-negative coefficients (q = t0 - t1 free, p_i >= 0)
  // and a free output offset. The m x (n + 2) matrix is never stored: the operators are
  // simulated once, and the rows [1, columns, sign y] are folded into the triangular factor
  // of a QR, kBlock rows at a time (Householder on [R; block]). The factor's rows after the
  // first (that of the ones column) are those of the centred columns and target:
  // R22^T R22 = Ac^T Ac, R22^T r2 = Ac^T bc, so that ||Ac t - bc||^2 = ||R22 t - r2||^2 + const.
  const Eigen::Index k = static_cast<Eigen::Index>(n) + 4;  // ones, x_m, -x_m, y_1..y_n, b
  constexpr Eigen::Index kBlock = 4096;
  Eigen::MatrixXd W = Eigen::MatrixXd::Zero(k + kBlock, k);  // [R; block]
  Eigen::VectorXd sums = Eigen::VectorXd::Zero(k);             // column sums (for the means)
  Eigen::Index filled = 0;
  bool have_r = false;
  auto fold = [&]() {
    if (filled == 0) return;
    const Eigen::Index top = have_r ? k : 0;
    Eigen::Ref<Eigen::MatrixXd> S = W.topRows(top + filled);
    Eigen::HouseholderQR<Eigen::Ref<Eigen::MatrixXd>> qr(S);  // in place: R in S's upper triangle
    const Eigen::Index rk = std::min(top + filled, k);
    Eigen::MatrixXd R = Eigen::MatrixXd::Zero(k, k);
    R.topRows(rk) = S.topRows(rk).triangularView<Eigen::Upper>();
    W.topRows(k) = R;
    have_r = true;
    filled = 0;
  };
  const Structure<double> s = canonical_structure(pi);
  std::vector<double> ops(n, 0.0);  // virgin
  for (std::size_t i = 0; i < r.end; ++i) {
    double u = 0.0;
    structure_step(s, x[i] - x0, ops.data(), &u);
    if (i < r.begin) continue;
    const Eigen::Index row = (have_r ? k : 0) + filled;
    W(row, 0) = 1.0;
    W(row, 1) = u;
    W(row, 2) = -u;
    for (std::size_t j = 0; j < n; ++j) W(row, static_cast<Eigen::Index>(j + 3)) = ops[j];
    W(row, k - 1) = sign * y[i];
    for (Eigen::Index c = 0; c < k; ++c) sums(c) += W(row, c);
    if (++filled == kBlock) fold();
  }
  fold();
  const double m = static_cast<double>(r.end - r.begin);
  const Eigen::MatrixXd R22 = W.block(1, 1, k - 2, k - 2);
  const Eigen::VectorXd r2 = W.block(1, k - 1, k - 2, 1);
  const Eigen::VectorXd t = detail::bounded_ls(R22, r2, Eigen::VectorXd::Zero(k - 2), nullptr);
  const double offset = sums(k - 1) / m - (sums.segment(1, k - 2) / m).dot(t);  // the free output offset
  pi.q = t(0) - t(1);
  for (std::size_t i = 0; i < n; ++i) pi.p[i] = t(static_cast<Eigen::Index>(i + 2));
  pi.units.input_origin = x0;
  pi.units.output_offset = sign * offset;
  pi.units.output_gain = sign;
  pi.input_limits = Limits{*lo, *hi};
  if (pi.q == 0.0 && std::all_of(pi.p.begin(), pi.p.end(), [](double v) { return v == 0.0; }))
    pi.q = std::numeric_limits<double>::min();  // constant model; keep it a valid PI
  return pi;
}

}  // namespace hysteron
