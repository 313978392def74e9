// The dead-zone MPI (FitModel::mpi_deadzone, Kuhnen): the PI's cumulative slopes plus
// forward dead zones on fixed thresholds over the output range, with cumulative
// dead-zone slopes per side; starts from constrained LS (with and without dead zones).
#include <algorithm>
#include <cmath>
#include <limits>

#include "hysteron/error.hpp"
#include "kinds.hpp"

namespace hysteron::fitting {

namespace {

// Threshold scales f of the seeds r_i = f i span(x) / (2n) (see starts()).
constexpr double kThresholdScales[] = {1.0, 0.5, 0.25, 0.125};
// A dead-zone threshold within this fraction of the output span from 0 is dropped
// (a dead zone at 0 is the identity).
constexpr double kZeroThreshold = 1e-6;

class MpiDeadzoneKind final : public SlopeParametrization {
 public:
  bool handles(const FitOptions& o) const override { return o.model == FitModel::mpi_deadzone; }
  int num_parameters(const FitOptions& o) const override { return o.num_operators + 1 + o.num_dead_zones; }
  // q and the p_i scale with b / a (absorb_scales), the thresholds with a
  // (the dead-zone slopes g_j are unitless).
  double absorbed_factor(std::string_view name, double a, double b) const override {
    return name == "q" || name.starts_with("p[") ? b / a : 1.0;
  }

 protected:
  Starts starts(const Data& d, const Ranges& rg, const FitOptions& o) const override {
    const std::span<const double> x = d.x, y = d.y;
    const IndexRange tr = d.train;
    const std::size_t m = tr.end - tr.begin;
    const int n = o.num_operators;
    const auto xs = x.subspan(tr.begin, m);
    WeightFitOptions wo;
    wo.initial_state = o.initial_state;
    wo.train = tr;
    wo.margin = o.min_slope;
    wo.free_offset = d.free_offset;
    SlopeLayout layout;
    layout.kind = FitModel::mpi_deadzone;
    std::vector<std::vector<double>> starts;
    MpiDeadzoneParams dz;
    dz.p.assign(static_cast<std::size_t>(std::max(0, n - 1)), 0.0);
    const int J = o.num_dead_zones;
    for (int j = 1; j <= J; ++j) {
      const double z = rg.ylo + j * rg.yspan() / (J + 1);
      if (std::abs(z) > kZeroThreshold * rg.yspan()) dz.z.push_back(z);
    }
    dz.g.assign(dz.z.size(), 0.0);
    // Threshold scale: r_i = f i span(x) / (2n) for f in kThresholdScales, weights
    // by constrained LS; ranked by the SSE of the training record plus that of a
    // second pass of the same input (the model continued from the state the first
    // pass leaves). One loop from the virgin state cannot tell wide thresholds
    // (whose virgin ascent differs from every later one) from narrow ones; the
    // second pass can (rig record: 16 mm validation RMS with f = 1).
    MpiDeadzoneParams fw;
    {
      std::vector<double> x2(x.begin(), x.begin() + static_cast<std::ptrdiff_t>(tr.end));
      x2.insert(x2.end(), xs.begin(), xs.end());
      double best_sse = std::numeric_limits<double>::infinity();
      for (double f : kThresholdScales) {
        dz.r = default_thresholds(xs, n);
        for (double& ri : dz.r) ri *= f;
        MpiDeadzoneParams c;
        try {
          c = std::get<MpiDeadzoneParams>(fit_weights(dz, x, y, wo));
        } catch (const Error&) {
          continue;
        }
        const std::vector<double> y2 = simulate_record(c, x2, o.initial_state);
        double sse = 0;
        for (std::size_t k = tr.begin; k < tr.end; ++k) {
          const double e1 = y[k] - y2[k], e2 = y[k] - y2[tr.end + k - tr.begin];
          sse += e1 * e1 + e2 * e2;
        }
        if (sse < best_sse) best_sse = sse, fw = c;
      }
      if (!std::isfinite(best_sse)) throw Error("fit: mpi-deadzone: no usable start");
    }
    layout.r = canonical_structure(fw).r;
    // forward dead zones of the seed, split by side (ascending / descending away from 0)
    std::vector<std::pair<double, double>> pos, neg;
    for (std::size_t j = 0; j < fw.z.size(); ++j) (fw.z[j] > 0 ? pos : neg).push_back({fw.z[j], fw.g[j]});
    std::sort(pos.begin(), pos.end());
    std::sort(neg.begin(), neg.end(), std::greater<>());
    std::vector<double> seedA = slopes(fw.q, fw.p), seedB;
    for (auto* side : {&pos, &neg}) {
      double c = 1.0;
      for (auto& [z, g] : *side) {
        (side == &pos ? layout.zp : layout.zn).push_back(z);
        c += g;
        seedA.push_back(c);
      }
    }
    // second start: the classical PI (no dead-zone action)
    PiParams pi;
    pi.r = layout.r;
    pi.p.assign(pi.r.size(), 0.0);
    const auto fp = std::get<PiParams>(fit_weights(pi, x, y, wo));
    seedB = slopes(fp.q, fp.p);
    seedB.resize(seedA.size(), 1.0);
    if (canonical_structure(fp).r.size() == layout.r.size()) starts.push_back(seedB);
    starts.push_back(seedA);
    layout.ridge = std::sqrt(o.weight_regularization * static_cast<double>(m)) * rg.xspan();
    return {std::vector<SlopeLayout>(starts.size(), layout), std::move(starts)};
  }
  ModelParams model(const SlopeLayout& L, const double* th) const override {
    Structure<double> s;
    L.build(th, s);
    MpiDeadzoneParams m;
    m.q = s.q;
    m.r = s.r;
    m.p = s.p;
    m.g0 = 1.0;
    m.z = s.z;
    m.g = s.g;
    return m;
  }
  // The model file's keys: q, p[i], g[j] (g0 = 1 is fixed).
  std::vector<std::string> names(const SlopeLayout& L) const override {
    std::vector<std::string> out{"q"};
    for (std::size_t i = 0; i < L.r.size(); ++i) out.push_back(indexed("p", i));
    for (std::size_t j = 0; j < L.zp.size() + L.zn.size(); ++j) out.push_back(indexed("g", j));
    return out;
  }
  Eigen::MatrixXd report_map(const SlopeLayout& L) const override { return cumulative_report_map(L); }
  // g_1 = D_1 - g0 on each side (g0 = 1).
  Eigen::VectorXd report_shift(const SlopeLayout& L) const override {
    Eigen::VectorXd c = Eigen::VectorXd::Zero(L.size());
    const auto first = static_cast<Eigen::Index>(L.env + L.r.size() + 1);
    if (!L.zp.empty()) c(first) = -1.0;
    if (!L.zn.empty()) c(first + static_cast<Eigen::Index>(L.zp.size())) = -1.0;
    return c;
  }
};

}  // namespace

const Parametrization& mpi_deadzone_kind() {
  static const MpiDeadzoneKind k;
  return k;
}

}  // namespace hysteron::fitting
