// The normalised Bouc-Wen model (FitModel::bouc_wen, models.hpp): kx, kw, rho, sigma, n
// and the output offset by LM (Ceres, automatic derivatives through the recursion of
// the kernel: bouc_wen_increment, explicit steps of dw/dx, w clamped to [-1, 1]), from a grid
// of starts over both loop orientations; the smallest slope over all states >= min_slope
// keeps it invertible. LM works on the compressed problem (BoucWenLm); the Huber loss is
// in the residuals (robust_residual), as for the other kinds.
#include <ceres/ceres.h>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>

#include "../core/kernels.hpp"
#include "detail.hpp"
#include "hysteron/error.hpp"
#include "kinds.hpp"

namespace hysteron::fitting {

namespace {

constexpr int kBw = 6;  // kx, kw, rho, sigma, n, offset
// Upper bounds of sigma, n and rho (normalised input: span 1): beyond them the loop is a
// relay-like corner that the sampled record cannot resolve.
constexpr double kSigmaMax = 20.0, kNMax = 10.0, kRhoMax = 1e4;
// sigma >= 1/2: unloading then moves w at least at the rate rho (dw/ds = -rho (1 + (2 sigma
// - 1) |w|^n) for a travel s back); below it, w = +-1 is an unstable rest point of the
// unloading branch (at sigma = 0 the loop never leaves saturation) and the output's
// sensitivity to sigma grows like exp(rho n s): the fit would be ill-posed there.
constexpr double kSigmaMin = 0.5;

inline double scalar(double v) { return v; }
template <class J>
double scalar(const J& v) {
  return v.a;
}

// theta = [s, kw, rho, sigma, n, offset]: s is the smallest slope of the output over all
// states (invertible for s > 0, see BoucWenParams), kx = s + max(0, -kw) rho max(1, 2 sigma).
template <class T>
T min_slope_to_kx(const T* th) {
  if (scalar(th[1]) >= 0) return th[0];
  return th[0] - th[1] * bouc_wen_max_dwdx(th[2], th[3]);
}

// The residuals kx x_k + kw w_k + c - y_k of the training rows in order, mapped by
// robust_residual (--huber: f^2 is the Huber loss of r, over d if d < 1): emit(f), f of type T
// (double, or a Jet carrying the row of the Jacobian).
template <class T, class Emit>
void bouc_wen_pass(const Data& d, const T* th, Emit&& emit) {
  const T& kw = th[1];
  const T kx = min_slope_to_kx(th);
  const T& rho = th[2];
  const T& sigma = th[3];
  const T& n = th[4];
  const T& c = th[5];
  // virgin = relaxed at 0 (the kernel's reset); relaxed at x[0]
  double xp = d.initial == InitialState::relaxed ? d.x[0] : 0.0;
  T w(0.0);
  for (std::size_t k = 0; k < d.train.end; ++k) {
    w = detail::bouc_wen_increment<T>(w, d.x[k] - xp, rho, sigma, n, [](const T& v) { return scalar(v); });
    xp = d.x[k];
    if (k >= d.train.begin) emit(robust_residual<T>(kx * d.x[k] + kw * w + c - d.y[k], d.huber));
  }
}

struct BoucWenResiduals {
  const Data* d;
  template <class T>
  bool operator()(const T* th, T* res) const {
    T* out = res;
    bouc_wen_pass(*d, th, [&](const T& f) { *out++ = f; });
    return true;
  }
};

// The m residuals (automatic derivatives through the whole record).
ceres::CostFunction* make_full_cost(const Data& d) {
  const int m = static_cast<int>(d.train.end - d.train.begin);
  return new ceres::AutoDiffCostFunction<BoucWenResiduals, ceres::DYNAMIC, kBw>(new BoucWenResiduals{&d}, m);
}

// The compressed problem (make_compressed_row_cost) of the same rows.
ceres::CostFunction* make_compressed_cost(const Data& d) {
  return make_compressed_row_cost(
      kBw, [dd = d](const double* th, bool want_j, const std::function<void(double, const double*)>& add) {
        if (!want_j) {
          bouc_wen_pass(dd, th, [&](double f) { add(f, nullptr); });
          return true;
        }
        using J = ceres::Jet<double, kBw>;
        J t[kBw];
        for (int i = 0; i < kBw; ++i) t[i] = J(th[i], i);
        bouc_wen_pass(dd, static_cast<const J*>(t), [&](const J& f) { add(f.a, f.v.data()); });
        return true;
      });
}

// LM gets the compressed problem (make_compressed_row_cost: 7 residuals [Q^T r; ||(I - Q
// Q^T) r||], Jacobian [R; 0]; the same cost, J^T r and J^T J, so the same steps to rounding)
// instead of the m residuals and the m x 6 Jacobian (issue 13: `fit` memory). The rows are
// those of BoucWenResiduals: the same Jets of kBw derivatives that
// ceres::AutoDiffCostFunction evaluates, one row at a time. With --huber the rows are the
// robust residuals, so both problems minimise the same residual vector. (A ceres::HuberLoss,
// as before, cannot be compressed, and it was not a per-row loss: Ceres applies a loss to a
// block's squared norm, and the m rows were one block: rho(||r||^2) = 2 d ||r|| - d^2.)
struct BoucWenLm final : LmProblem {
  bool compressed() const override { return lm_compression(); }
  void add_costs(ceres::Problem& problem, const Data& d, double* theta) const override {
    problem.AddResidualBlock(compressed() ? make_compressed_cost(d) : make_full_cost(d), nullptr, theta);
    problem.SetParameterUpperBound(theta, 2, kRhoMax);
    problem.SetParameterUpperBound(theta, 3, kSigmaMax);
    problem.SetParameterUpperBound(theta, 4, kNMax);
  }
};

BoucWenParams params_of(const double* th) {
  return BoucWenParams{min_slope_to_kx(th), th[1], th[2], th[3], th[4], {}, {}};
}

// d(kx, kw, rho, sigma, n) / d theta (the reported parameters).
Eigen::MatrixXd report_jacobian(const double* th) {
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(5, kBw);
  M.block(1, 1, 4, 4).setIdentity();
  using J = ceres::Jet<double, kBw>;  // dkx / dtheta by automatic differentiation
  J t[kBw];
  for (int i = 0; i < kBw; ++i) t[i] = J(th[i], i);
  const J kx = min_slope_to_kx(t);
  for (int i = 0; i < kBw; ++i) M(0, i) = kx.v(i);
  return M;
}

class BoucWenKind final : public Parametrization {
 public:
  bool handles(const FitOptions& o) const override { return o.model == FitModel::bouc_wen; }
  int num_parameters(const FitOptions&) const override { return kBw; }
  // w is unitless: kx -> (b / a) kx, kw -> b kw, rho -> rho / a.
  double absorbed_factor(std::string_view name, double a, double b) const override {
    if (name == "kx") return b / a;
    if (name == "kw") return b;
    return name == "rho" ? 1.0 / a : 1.0;
  }
  void fit(const Data& d, const Ranges& rg, const FitOptions& o, FitReport& rep) const override {
    // Starts: w saturates after an input travel of about 1 / rho; a loop of height
    // 2 kw around a line of slope kx. Grid over rho (input spans) and n.
    double xm = 0, ym = 0;
    for (std::size_t k = d.train.begin; k < d.train.end; ++k) xm += d.x[k], ym += d.y[k];
    const double mm = static_cast<double>(d.train.end - d.train.begin);
    xm /= mm;
    ym /= mm;
    const double slope = rg.yspan() / rg.xspan();
    std::vector<std::vector<double>> starts, lowers;
    // both loop orientations: kw < 0 (counterclockwise, actuators) and kw > 0
    for (double sgn : {-1.0, 1.0})
      for (double n : {1.0, 2.0})
        for (double rho : {3.0, 10.0}) {
          const double kw = sgn * 0.15 * rg.yspan(), s = 0.5 * slope;
          const double th[kBw] = {s, kw, rho / rg.xspan(), 1.0, n, 0.0};
          const double kx = min_slope_to_kx(th);
          starts.push_back({s, kw, rho / rg.xspan(), 1.0, n, ym - kx * xm});
        }
    const double inf = std::numeric_limits<double>::infinity();
    const std::vector<double> lower{o.min_slope * slope, -inf, 1e-3 / rg.xspan(), kSigmaMin, 1.0, -inf};
    lowers.assign(starts.size(), lower);
    const std::vector<int> held = d.free_offset ? std::vector<int>{} : std::vector<int>{5};
    if (!d.free_offset)
      for (auto& s : starts) s[5] = 0.0;
    const BoucWenLm lm;
    std::vector<const LmProblem*> problems(starts.size(), &lm);
    auto [solved, kbest] = solve_starts(problems, d, starts, lowers, held, o, rep);
    if (kbest == std::string::npos) {
      rep.status = FitStatus::failed;
      rep.message = "no start gave a usable solution";
      return;
    }
    const Solved& best = solved[kbest];
    finish_status(rep, best, /*start_is_minimum=*/false);
    rep.initial_cost = best.initial_cost;
    rep.final_cost = best.final_cost;
    rep.iterations = best.iterations;
    BoucWenParams m = params_of(best.theta.data());
    m.units.output_offset = best.theta[5];
    rep.model = m;
    const char* names[] = {"kx", "kw", "rho", "sigma", "n"};
    const double values[] = {m.kx, m.kw, m.rho, m.sigma, m.n};
    for (int i = 0; i < 5; ++i) {
      FitParameter p{names[i], values[i]};
      // on a lower bound: the smallest slope (min_slope), sigma (1/2), n (1)
      p.at_bound = (i == 0 || i >= 3) &&
                   best.theta[static_cast<std::size_t>(i)] <= lower[static_cast<std::size_t>(i)] * (1 + 1e-9) + 1e-300;
      rep.parameters.push_back(p);
    }
    // sse = 2 x the final cost, that of the robust residuals with --huber: their Jacobian
    // carries the same 1/sqrt(d) scale (robust_residual), so s^2 (J^T J)^-1 does not.
    if (o.compute_covariance) standard_errors(lm, d, best.theta, lower, held, report_jacobian(best.theta.data()), 2 * best.final_cost, rep);
  }
};

}  // namespace

const Parametrization& bouc_wen_kind() {
  static const BoucWenKind k;
  return k;
}

}  // namespace hysteron::fitting

namespace hysteron::detail {

LmNormalEquations bouc_wen_normal_equations(std::span<const double> theta, std::span<const double> x,
                                            std::span<const double> y, IndexRange train, InitialState initial,
                                            double huber, bool compressed) {
  if (theta.size() != static_cast<std::size_t>(fitting::kBw))
    throw Error("bouc_wen_normal_equations: theta must have 6 entries");
  if (x.size() != y.size() || x.empty() || train.begin >= train.end || train.end > x.size())
    throw Error("bouc_wen_normal_equations: bad record or range");
  fitting::Data d{x, y, train, initial, huber};
  const std::unique_ptr<ceres::CostFunction> cost(compressed ? fitting::make_compressed_cost(d)
                                                             : fitting::make_full_cost(d));
  LmNormalEquations out;
  out.residuals = cost->num_residuals();
  Eigen::VectorXd r(out.residuals);
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> J(out.residuals, fitting::kBw);
  const double* params[1] = {theta.data()};
  double* jacs[1] = {J.data()};
  if (!cost->Evaluate(params, r.data(), jacs)) throw Error("bouc_wen_normal_equations: the cost cannot be evaluated");
  out.cost = 0.5 * r.squaredNorm();
  out.gradient = J.transpose() * r;
  out.jtj = J.transpose() * J;
  return out;
}

}  // namespace hysteron::detail
