// The kinds beyond the PI family that are linear in their weights (preisach, kp,
// maxwell-slip, rate-pi): their hysterons are fixed by a grid or thresholds over the
// training range, the weights come from bounded linear least squares (Lawson-Hanson)
// with the bounds that keep the model invertible: the direct slope >= min_slope (of the
// normalised data's span ratio, 1) and every hysteron weight >= 0. rate-pi adds a
// golden-section search over its rate coefficient c, for four filter time constants tau,
// around the least squares.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include "../core/kernels.hpp"
#include "detail.hpp"
#include "hysteron/error.hpp"
#include "kinds.hpp"

namespace hysteron::fitting {

namespace {

// Rows of the least squares: all of the training range up to FitOptions::max_ls_rows; beyond,
// one row per block of `stride` samples at block_offset (the model is still simulated
// through every sample; the final cost uses all of them). A fixed position per block aliased
// with a periodic input (a dither of period 4 on 24000 rows: every row at one phase of it,
// kp 1.88 % of span against 0.75 %). The design holds at most kMaxDesignEntries doubles (160 MB),
// but never fewer than kMinRows rows.
constexpr std::size_t kMaxDesignEntries = 20'000'000;
constexpr std::size_t kMinRows = 6000;
// Huber loss: iteratively reweighted least squares passes.
constexpr int kIrlsPasses = 6;

// The row of block b (of `stride` samples) of a range of m samples: a hash of b (splitmix64)
// modulo the block's length, so no periodic input can alias with it. It depends on b only: a
// transformed record (offset, scale, sign) gets the same rows.
std::size_t block_offset(std::size_t b, std::size_t stride, std::size_t m) {
  std::uint64_t z = (static_cast<std::uint64_t>(b) + 1) * 0x9e3779b97f4a7c15ULL;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  z ^= z >> 31;
  return static_cast<std::size_t>(z % std::min(stride, m - b * stride));
}

struct Design {
  Eigen::MatrixXd A;
  Eigen::VectorXd b;
};

// Regressors of a kernel model (kernels.hpp: features) through the record from sample 0.
Design design(const ModelParams& mp, const Data& d, std::size_t max_rows) {
  auto k = detail::make_kernel(mp);
  if (d.initial == InitialState::relaxed) k->reset_relaxed(d.x[0]); else k->reset();
  const std::size_t m = d.train.end - d.train.begin;
  const std::size_t nf = k->num_features();
  // at most kMaxDesignEntries entries (never fewer rows than kMinRows): a 60-level preisach has
  // 1831 regressors
  if (max_rows != 0)
    max_rows = std::min(max_rows, std::max(kMinRows, kMaxDesignEntries / std::max<std::size_t>(nf, 1)));
  const std::size_t stride = max_rows == 0 || m <= max_rows ? 1 : (m - 1) / max_rows + 1;
  const std::size_t rows = m == 0 ? 0 : (m - 1) / stride + 1;
  Design D{Eigen::MatrixXd(static_cast<Eigen::Index>(rows), static_cast<Eigen::Index>(nf)),
           Eigen::VectorXd(static_cast<Eigen::Index>(rows))};
  std::vector<double> f(nf);
  Eigen::Index row = 0;
  std::size_t chosen = 0;
  for (std::size_t i = 0; i < d.train.end; ++i) {
    k->step(d.x[i]);
    if (i < d.train.begin) continue;
    const std::size_t t = i - d.train.begin;
    if (t % stride == 0) chosen = t + block_offset(t / stride, stride, m);
    if (t == chosen) {
      k->features(d.x[i], f.data());
      for (std::size_t j = 0; j < nf; ++j) D.A(row, static_cast<Eigen::Index>(j)) = f[j];
      D.b(row) = d.y[i];
      ++row;
    }
  }
  return D;
}

struct Solution {
  Eigen::VectorXd t;
  double offset = 0.0;
  double sse = 0.0;
};

// Hysterons that behave alike over the training rows (equal columns of A, centred if the
// offset is free, to kTieTol: relays or kernels in one cell of the record's memory staircase)
// cannot be told apart by the least squares, whose active set gave all the weight to the
// first of them in the grid's order (an order that a negated input reverses: kp validated
// 3.5 % vs 21 % on the Festo record). They are solved as one column; the group's weight goes
// to its narrowest hysterons (the least hysteresis the record shows; equal shares among
// equally narrow ones), or in equal shares if the kind gives no widths. Both choices are
// the same for any order of the columns and mirror with the input. The columns are O(1)
// (normalised input, relay and ramp outputs in [0, 1]): kTieTol is absolute.
constexpr double kTieTol = 1e-9;

struct Ties {
  std::vector<Eigen::Index> group;   // per column of A: its column in the reduced design
  std::vector<Eigen::Index> count;   // per reduced column: number of columns of A in it
  bool any() const { return count.size() < group.size(); }
};

// Groups the columns of A with equal lower bounds that are equal to kTieTol (column 0, the
// direct slope, alone).
Ties find_ties(const Eigen::MatrixXd& A, const Eigen::VectorXd& lo, bool centre) {
  const Eigen::Index n = A.cols();
  Ties t;
  t.group.assign(static_cast<std::size_t>(n), 0);
  if (n == 0 || A.rows() == 0) return t;
  const Eigen::RowVectorXd mean = centre ? Eigen::RowVectorXd(A.colwise().mean()) : Eigen::RowVectorXd::Zero(n);
  // candidates sorted by a fixed weighted sum of their (centred) rows, weights in [0.5, 1.5) from
  // the golden-ratio sequence: equal columns are within kTieTol sum(w) there, and distinct ones
  // rarely are (the first row alone was 0 or 1 for every relay of an uncentred Huber fit, which
  // made the search quadratic in the columns)
  Eigen::VectorXd w(A.rows());
  for (Eigen::Index r = 0; r < A.rows(); ++r) {
    const double f = static_cast<double>(r) * 0.6180339887498949;
    w(r) = 0.5 + (f - std::floor(f));
  }
  const double window = kTieTol * w.sum();
  const Eigen::RowVectorXd key = (w.transpose() * A).array() - mean.array() * w.sum();
  std::vector<Eigen::Index> order(static_cast<std::size_t>(n));
  for (Eigen::Index j = 0; j < n; ++j) order[static_cast<std::size_t>(j)] = j;
  std::stable_sort(order.begin() + 1, order.end(), [&](Eigen::Index a, Eigen::Index b) { return key(a) < key(b); });
  std::vector<Eigen::Index> head(static_cast<std::size_t>(n), -1);  // per column: its group's first column
  head[0] = 0;
  for (std::size_t k = 1; k < order.size(); ++k) {
    const Eigen::Index j = order[k];
    for (std::size_t c = k; c-- > 1 && key(j) - key(order[c]) <= window;) {
      const Eigen::Index i = order[c];
      if (head[static_cast<std::size_t>(i)] != i || lo(i) != lo(j)) continue;
      if (((A.col(i) - A.col(j)).array() - (mean(i) - mean(j))).abs().maxCoeff() <= kTieTol) {
        head[static_cast<std::size_t>(j)] = i;
        break;
      }
    }
    if (head[static_cast<std::size_t>(j)] < 0) head[static_cast<std::size_t>(j)] = j;
  }
  // reduced columns in the order of their first member
  std::vector<Eigen::Index> slot(static_cast<std::size_t>(n), -1);
  for (Eigen::Index j = 0; j < n; ++j) {
    const auto h = static_cast<std::size_t>(head[static_cast<std::size_t>(j)]);
    if (slot[h] < 0) {
      slot[h] = static_cast<Eigen::Index>(t.count.size());
      t.count.push_back(0);
    }
    t.group[static_cast<std::size_t>(j)] = slot[h];
    ++t.count[static_cast<std::size_t>(slot[h])];
  }
  return t;
}

// min ||A t + c - b|| (Huber: reweighted), t >= lo, offset c free if d.free_offset.
Solution solve_distinct(const Design& D, const Eigen::VectorXd& lo, const Data& d);

// width: per column, the hysteron's width in grid cells (empty: no widths, equal shares).
Solution solve(const Design& D, const Eigen::VectorXd& lo, const Data& d, const std::vector<int>& width = {}) {
  const Ties ties = find_ties(D.A, lo, d.free_offset);
  if (!ties.any()) return solve_distinct(D, lo, d);
  // the reduced design: the mean column of each group, its lower bound the sum of theirs
  const auto m = static_cast<Eigen::Index>(ties.count.size());
  Design R{Eigen::MatrixXd::Zero(D.A.rows(), m), D.b};
  Eigen::VectorXd rlo = Eigen::VectorXd::Zero(m);
  for (Eigen::Index j = 0; j < D.A.cols(); ++j) {
    const Eigen::Index g = ties.group[static_cast<std::size_t>(j)];
    R.A.col(g) += D.A.col(j) / static_cast<double>(ties.count[static_cast<std::size_t>(g)]);
    rlo(g) += lo(j);
  }
  Solution s = solve_distinct(R, rlo, d);
  // the members that take the group's weight: the narrowest (all if no widths)
  const auto w = [&](Eigen::Index j) { return width.empty() ? 0 : width[static_cast<std::size_t>(j)]; };
  std::vector<int> narrowest(static_cast<std::size_t>(m), std::numeric_limits<int>::max());
  std::vector<int> takers(static_cast<std::size_t>(m), 0);
  for (Eigen::Index j = 0; j < D.A.cols(); ++j) {
    const auto g = static_cast<std::size_t>(ties.group[static_cast<std::size_t>(j)]);
    narrowest[g] = std::min(narrowest[g], w(j));
  }
  for (Eigen::Index j = 0; j < D.A.cols(); ++j) {
    const auto g = static_cast<std::size_t>(ties.group[static_cast<std::size_t>(j)]);
    takers[g] += w(j) == narrowest[g];
  }
  const Eigen::VectorXd tr = s.t;
  s.t.resize(D.A.cols());
  for (Eigen::Index j = 0; j < D.A.cols(); ++j) {
    const auto g = static_cast<std::size_t>(ties.group[static_cast<std::size_t>(j)]);
    const Eigen::Index gi = static_cast<Eigen::Index>(g);
    // the others keep their lower bound; the takers share the rest
    const double rest = tr(gi) - lo(j) * static_cast<double>(ties.count[g] - takers[g]);
    s.t(j) = w(j) == narrowest[g] ? rest / static_cast<double>(takers[g]) : lo(j);
  }
  return s;
}

Solution solve_distinct(const Design& D, const Eigen::VectorXd& lo, const Data& d) {
  Solution s;
  const bool free = d.free_offset;
  s.t = detail::bounded_ls(D.A, D.b, lo, free ? &s.offset : nullptr, &s.sse);
  if (d.huber > 0) {
    for (int pass = 0; pass < kIrlsPasses; ++pass) {
      const Eigen::VectorXd r = D.A * s.t + Eigen::VectorXd::Constant(D.b.size(), s.offset) - D.b;
      Eigen::VectorXd sw(r.size());
      for (Eigen::Index i = 0; i < r.size(); ++i) sw(i) = std::sqrt(std::min(1.0, d.huber / std::max(std::abs(r(i)), 1e-300)));
      // the offset column is weighted too: fold it into the design
      Eigen::MatrixXd Aw = sw.asDiagonal() * D.A;
      Eigen::VectorXd bw = sw.asDiagonal() * D.b;
      if (free) {
        Aw.conservativeResize(Eigen::NoChange, Aw.cols() + 1);
        Aw.col(Aw.cols() - 1) = sw;
        Eigen::VectorXd lw(lo.size() + 1);
        lw << lo, -1e300;
        const Eigen::VectorXd t = detail::bounded_ls(Aw, bw, lw, nullptr);
        s.t = t.head(lo.size());
        s.offset = t(lo.size());
      } else {
        s.t = detail::bounded_ls(Aw, bw, lo, nullptr);
      }
    }
    s.sse = (D.A * s.t + Eigen::VectorXd::Constant(D.b.size(), s.offset) - D.b).squaredNorm();
  }
  return s;
}

Eigen::VectorXd lower_bounds(Eigen::Index n, const FitOptions& o) {
  Eigen::VectorXd lo = Eigen::VectorXd::Zero(n);
  lo(0) = o.min_slope;  // the direct slope (normalised data: span ratio 1)
  return lo;
}

std::span<const double> train_x(const Data& d) { return d.x.subspan(d.train.begin, d.train.end - d.train.begin); }

// Fills the report of a linear kind: status, costs, model, named parameters.
// The direct slope (first parameter) on its bound min_slope is reported at_bound; weights
// at 0 are not (most hysterons of a grid are unused by a given record).
void finish(FitReport& rep, const Data& d, ModelParams model, const std::vector<std::string>& names,
            const std::vector<double>& values, std::string how, int solves, double min_slope) {
  if (d.free_offset) {  // exact over all training samples (the LS may have used a subset of the rows)
    units_map(model).output_offset = 0.0;
    units_map(model).output_offset = projected_offset(model, d);
  }
  double ym = 0, s0 = 0;
  for (std::size_t j = d.train.begin; j < d.train.end; ++j) ym += d.y[j];
  ym /= static_cast<double>(d.train.end - d.train.begin);
  for (std::size_t j = d.train.begin; j < d.train.end; ++j) s0 += (d.y[j] - ym) * (d.y[j] - ym);
  rep.initial_cost = 0.5 * s0;  // the constant model
  rep.final_cost = 0.5 * model_sse(model, d);
  rep.iterations = solves;
  rep.total_iterations += solves;
  rep.num_starts = 1;
  rep.model = std::move(model);
  rep.status = std::isfinite(rep.final_cost) ? FitStatus::converged : FitStatus::failed;
  rep.message = std::move(how);
  for (std::size_t i = 0; i < names.size(); ++i)
    rep.parameters.push_back({names[i], values[i], std::numeric_limits<double>::quiet_NaN(), false,
                              i == 0 && values[0] <= min_slope * (1 + 1e-9)});
  rep.covariance_note = "standard errors are not computed for the bounded linear least squares of this kind";
}

std::string ls_message(const Design& D, std::size_t m) {
  return fmt::format("bounded linear least squares (Lawson-Hanson) on {} of {} training samples, {} regressors",
                     D.A.rows(), m, D.A.cols());
}

// ---- preisach and kp --------------------------------------------------------------

template <class G>
class GridKind final : public Parametrization {
 public:
  explicit GridKind(FitModel kind) : kind_(kind) {}
  bool handles(const FitOptions& o) const override { return o.model == kind_; }
  int num_parameters(const FitOptions& o) const override { return o.num_operators * (o.num_operators + 1) / 2 + 1; }
  double absorbed_factor(std::string_view name, double a, double b) const override {
    return name == "q" ? b / a : name.starts_with("w[") ? b : 1.0;
  }
  void fit(const Data& d, const Ranges& rg, const FitOptions& o, FitReport& rep) const override {
    G g;
    g.levels = o.num_operators;
    g.lo = rg.xlo;
    g.hi = rg.xhi;
    g.q = 1.0;
    g.w.assign(static_cast<std::size_t>(g.levels * (g.levels + 1) / 2), 0.0);
    const Design D = design(g, d, o.max_ls_rows);
    // widths alpha - beta in grid cells: hysteron (i, j) has alpha = t_{i+1}, beta = t_j
    std::vector<int> width{0};  // the direct slope
    for (int i = 0; i < g.levels; ++i)
      for (int j = 0; j <= i; ++j) width.push_back(i + 1 - j);
    const Solution s = solve(D, lower_bounds(D.A.cols(), o), d, width);
    g.q = s.t(0);
    for (std::size_t k = 0; k < g.w.size(); ++k) g.w[k] = s.t(static_cast<Eigen::Index>(k + 1));
    g.units.output_offset = s.offset;
    std::vector<std::string> names{"q"};
    std::vector<double> values{g.q};
    for (std::size_t k = 0; k < g.w.size(); ++k) {
      names.push_back(indexed("w", k));
      values.push_back(g.w[k]);
    }
    finish(rep, d, g, names, values, ls_message(D, d.train.end - d.train.begin), 1, o.min_slope);
  }

 private:
  FitModel kind_;
};

// ---- maxwell-slip -----------------------------------------------------------------

class MaxwellSlipKind final : public Parametrization {
 public:
  bool handles(const FitOptions& o) const override { return o.model == FitModel::maxwell_slip; }
  int num_parameters(const FitOptions& o) const override { return o.num_operators; }
  double absorbed_factor(std::string_view name, double a, double b) const override {
    return name == "k0" || name.starts_with("k[") ? b / a : 1.0;
  }
  void fit(const Data& d, const Ranges&, const FitOptions& o, FitReport& rep) const override {
    // The play outputs y_i of the slip deflections (rate-pi's kernel with c = 0), then
    // the columns [x, x - y_i]: y = k0 x + sum k_i (x - y_i).
    RatePiParams plays;
    plays.r = default_thresholds(train_x(d), o.num_operators);
    plays.p.assign(plays.r.size(), 1.0);
    plays.dt = 1.0;
    Design D = design(plays, d, o.max_ls_rows);
    for (Eigen::Index j = 1; j < D.A.cols(); ++j) D.A.col(j) = D.A.col(0) - D.A.col(j);
    const Solution s = solve(D, lower_bounds(D.A.cols(), o), d);
    MaxwellSlipParams m;
    m.k0 = s.t(0);
    m.delta = plays.r;
    for (std::size_t i = 0; i < plays.r.size(); ++i) m.k.push_back(s.t(static_cast<Eigen::Index>(i + 1)));
    m.units.output_offset = s.offset;
    std::vector<std::string> names{"k0"};
    std::vector<double> values{m.k0};
    for (std::size_t i = 0; i < m.k.size(); ++i) {
      names.push_back(indexed("k", i));
      values.push_back(m.k[i]);
    }
    finish(rep, d, m, names, values, ls_message(D, d.train.end - d.train.begin), 1, o.min_slope);
  }
};

// ---- rate-pi ----------------------------------------------------------------------

// The rate filter's time constant from the record: a quarter of the shorter half periods
// (the 10th percentile of the intervals between input reversals, a reversal being a
// return by 10 % of the training span from the last extremum), so that the filtered
// rate settles within a half period of the fastest cycles.
double rate_time_constant(const Data& d, double dt) {
  const auto x = train_x(d);
  const auto [lo, hi] = std::minmax_element(x.begin(), x.end());
  const double band = 0.1 * (*hi - *lo);
  std::vector<double> intervals;
  double ext = x[0];
  int dir = 0;
  std::size_t last = 0;
  bool first = true;
  for (std::size_t k = 1; k < x.size(); ++k) {
    if (dir >= 0 && x[k] > ext) ext = x[k], dir = dir == 0 && x[k] > x[0] + band ? 1 : dir;
    if (dir <= 0 && x[k] < ext) ext = x[k], dir = dir == 0 && x[k] < x[0] - band ? -1 : dir;
    if (dir == 0) continue;
    if ((dir > 0 && x[k] < ext - band) || (dir < 0 && x[k] > ext + band)) {
      if (!first) intervals.push_back(static_cast<double>(k - last));
      first = false;
      last = k;
      dir = -dir;
      ext = x[k];
    }
  }
  if (intervals.empty()) return 0.25 * static_cast<double>(x.size()) * dt;
  std::sort(intervals.begin(), intervals.end());
  return 0.25 * intervals[intervals.size() / 10] * dt;
}

class RatePiKind final : public Parametrization {
 public:
  bool handles(const FitOptions& o) const override { return o.model == FitModel::rate_pi; }
  int num_parameters(const FitOptions& o) const override { return o.num_operators + 1; }
  double absorbed_factor(std::string_view name, double a, double b) const override {
    if (name == "q" || name.starts_with("p[")) return b / a;
    return name == "c" ? 1.0 / a : 1.0;
  }
  void fit(const Data& d, const Ranges&, const FitOptions& o, FitReport& rep) const override {
    if (!(o.sample_time > 0))
      throw Error("rate-pi: the sample time is unknown (its rates are per second): give sample_time, the seconds "
                  "between samples (hysteron fit: a time column or --sample-time)");
    RatePiParams m;
    m.dt = o.sample_time;
    m.r = default_thresholds(train_x(d), o.num_operators);
    m.p.assign(m.r.size(), 1.0);
    // tau: the data's time constant (rate_time_constant) times 1/2, 1, 2, 4; for each, c
    // by golden section in its admissible range; the pair of least cost is kept.
    const double tau0 = rate_time_constant(d, m.dt);
    const double rmax = m.r.empty() ? 0.0 : m.r.back();
    int solves = 0;
    auto at = [&](double tau, double c, Solution* out) {
      RatePiParams t = m;
      t.tau = tau;
      t.c = c;
      const Design D = design(t, d, o.max_ls_rows);
      Solution s = solve(D, lower_bounds(D.A.cols(), o), d);
      ++solves;
      if (out) *out = s;
      return s.sse;
    };
    double best_c = 0.0, best_tau = tau0, best_cost = at(tau0, 0.0, nullptr);  // the rate-independent end
    double cmax = 0.0;
    for (double f : {0.5, 1.0, 2.0, 4.0}) {
      const double tau = f * tau0;
      const double cm = rmax > 0 ? 0.5 * (tau + m.dt) / rmax * (1 - 1e-9) : 0.0;
      if (!(cm > 0)) continue;
      // golden section on c in [0, cm] (the cost is smooth in c; 24 steps: 1e-5 of the range)
      const double g = 0.5 * (std::sqrt(5.0) - 1);
      double a = 0, b = cm, c1 = b - g * (b - a), c2 = a + g * (b - a);
      double f1 = at(tau, c1, nullptr), f2 = at(tau, c2, nullptr);
      for (int it = 0; it < 24; ++it) {
        if (f1 <= f2) {
          b = c2, c2 = c1, f2 = f1, c1 = b - g * (b - a), f1 = at(tau, c1, nullptr);
        } else {
          a = c1, c1 = c2, f1 = f2, c2 = a + g * (b - a), f2 = at(tau, c2, nullptr);
        }
      }
      if (std::min(f1, f2) < best_cost) {
        best_cost = std::min(f1, f2);
        best_c = f1 <= f2 ? c1 : c2;
        best_tau = tau;
        cmax = cm;
      }
    }
    m.tau = best_tau;
    Solution s;
    at(best_tau, best_c, &s);
    m.c = best_c;
    m.q = s.t(0);
    for (std::size_t i = 0; i < m.r.size(); ++i) m.p[i] = s.t(static_cast<Eigen::Index>(i + 1));
    m.units.output_offset = s.offset;
    std::vector<std::string> names{"q"};
    std::vector<double> values{m.q};
    for (std::size_t i = 0; i < m.p.size(); ++i) {
      names.push_back(indexed("p", i));
      values.push_back(m.p[i]);
    }
    names.insert(names.end(), {"c", "tau"});
    values.insert(values.end(), {m.c, m.tau});
    finish(rep, d, m, names, values,
           fmt::format("golden-section search of c in [0, {:.4g}] (c max(r) <= (tau + dt) / 2) for tau = {:.4g} (x 1/2, 1, "
                       "2, 4 of {:.4g} from the reversal intervals; in the sample time's unit, s from the CLI) "
                       "around bounded linear least squares",
                       cmax, m.tau, tau0),
           solves, o.min_slope);
    rep.parameters.back().held = true;  // tau: chosen from a grid, no standard error
  }
};

}  // namespace

const Parametrization& preisach_kind() {
  static const GridKind<PreisachParams> k(FitModel::preisach);
  return k;
}
const Parametrization& kp_kind() {
  static const GridKind<KpParams> k(FitModel::kp);
  return k;
}
const Parametrization& maxwell_slip_kind() {
  static const MaxwellSlipKind k;
  return k;
}
const Parametrization& rate_pi_kind() {
  static const RatePiKind k;
  return k;
}

}  // namespace hysteron::fitting
