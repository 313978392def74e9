// The reference PI every fit is compared with (identify.hpp, reference_pi): what a
// 20-line script does with scipy's nnls, so that no model kind of hysteron is
// allowed to be worse than it without saying so.
#include <Eigen/Core>
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
  std::vector<double> xm(r.end);
  for (std::size_t k = 0; k < r.end; ++k) xm[k] = x[k] - x0;
  const Structure<double> s = canonical_structure(pi);
  const Eigen::MatrixXd phi = detail::regressors(s, xm, r, InitialState::virgin);  // [x_m, y_1..y_n]
  const Eigen::Index m = phi.rows(), cols = phi.cols();
  // Columns [x_m, -x_m, y_1..y_n] with non-negative coefficients: q = t0 - t1 free, p_i >= 0.
  Eigen::MatrixXd A(m, cols + 1);
  A.col(0) = phi.col(0);
  A.col(1) = -phi.col(0);
  A.rightCols(cols - 1) = phi.rightCols(cols - 1);
  // The output's sign (that of the least-squares line of y on x): a decreasing record
  // is fitted as -y with a negative output gain, so the reference is sign-equivariant.
  const double sign = detail::straight_line(x, y, r).slope < 0 ? -1.0 : 1.0;
  const Eigen::VectorXd b = sign * Eigen::Map<const Eigen::VectorXd>(y.data() + r.begin, m);
  double offset = 0.0;  // the free output offset
  const Eigen::VectorXd t = detail::bounded_ls(A, b, Eigen::VectorXd::Zero(A.cols()), &offset);
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
