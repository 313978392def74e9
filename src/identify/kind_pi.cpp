// The classical PI (FitModel::pi): identity envelope, n - 1 thresholds over half the
// input span, cumulative slopes q, q + p_1, ... (Eq. 11) seeded by constrained LS.
#include "kinds.hpp"

namespace hysteron::fitting {

namespace {

class PiKind final : public SlopeParametrization {
 public:
  bool handles(const FitOptions& o) const override { return o.model == FitModel::pi; }
  int num_parameters(const FitOptions& o) const override { return o.num_operators; }
  // q and the p_i scale with b / a (absorb_scales), the thresholds with a.
  double absorbed_factor(std::string_view name, double a, double b) const override {
    return name == "q" || name.starts_with("p[") ? b / a : 1.0;
  }

 protected:
  Starts starts(const Data& d, const Ranges&, const FitOptions& o) const override {
    WeightFitOptions wo;
    wo.initial_state = o.initial_state;
    wo.train = d.train;
    wo.margin = o.min_slope;
    wo.free_offset = d.free_offset;
    PiParams pi;
    pi.r = default_thresholds(d.x.subspan(d.train.begin, d.train.end - d.train.begin), o.num_operators);
    pi.p.assign(pi.r.size(), 0.0);
    const auto fw = std::get<PiParams>(fit_weights(pi, d.x, d.y, wo));
    SlopeLayout layout;
    layout.kind = FitModel::pi;
    layout.r = fw.r;
    return {{layout}, {slopes(fw.q, fw.p)}};
  }
  ModelParams model(const SlopeLayout& L, const double* th) const override {
    Structure<double> s;
    L.build(th, s);
    return PiParams{s.q, s.r, s.p, {}, {}};
  }
  // The model file's keys: q, p[0..n-2].
  std::vector<std::string> names(const SlopeLayout& L) const override {
    std::vector<std::string> out{"q"};
    for (std::size_t i = 0; i < L.r.size(); ++i) out.push_back(indexed("p", i));
    return out;
  }
  Eigen::MatrixXd report_map(const SlopeLayout& L) const override { return cumulative_report_map(L); }
};

}  // namespace

const Parametrization& pi_kind() {
  static const PiKind k;
  return k;
}

}  // namespace hysteron::fitting
