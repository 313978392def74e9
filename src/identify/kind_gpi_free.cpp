// The gpi with free weights (FitModel::gpi, FitOptions::gpi_free_weights): one tanh
// envelope and cumulative slopes on fixed thresholds r_i = alpha i, refined by LM from
// centre-line starts (starts.cpp: gpi_free_starts).
#include "kinds.hpp"

namespace hysteron::fitting {

namespace {

class GpiFreeKind final : public SlopeParametrization {
 public:
  bool handles(const FitOptions& o) const override { return o.model == FitModel::gpi && o.gpi_free_weights; }
  int num_parameters(const FitOptions& o) const override { return 4 + o.num_operators + 1; }
  // The envelope takes the scales; q and the p_i are unitless.
  double absorbed_factor(std::string_view name, double a, double b) const override {
    const double f = tanh_absorbed_factor(name, "", a, b);
    return f != 0.0 ? f : 1.0;
  }

 protected:
  Starts starts(const Data& d, const Ranges&, const FitOptions& o) const override {
    Starts st;
    gpi_free_starts(d, o.num_operators, o, std::max(o.positivity_margin, 1e-12), st.layouts, st.theta);
    return st;
  }
  ModelParams model(const SlopeLayout& L, const double* th) const override {
    Structure<double> s;
    L.build(th, s);
    GpiParams g;  // thresholds r_i, weights p_i
    g.envelope = Envelope::tanh(th[0], th[1], th[2], th[3]);
    g.q = s.q;
    g.n = static_cast<int>(s.r.size());
    g.r = s.r;
    g.p = s.p;
    return g;
  }
  // The model file's keys: c[0..3], q, p[i].
  std::vector<std::string> names(const SlopeLayout& L) const override {
    std::vector<std::string> out;
    for (std::size_t i = 0; i < 4; ++i) out.push_back(indexed("c", i));
    out.push_back("q");
    for (std::size_t i = 0; i < L.r.size(); ++i) out.push_back(indexed("p", i));
    return out;
  }
  Eigen::MatrixXd report_map(const SlopeLayout& L) const override { return cumulative_report_map(L); }
};

}  // namespace

const Parametrization& gpi_free_kind() {
  static const GpiFreeKind k;
  return k;
}

}  // namespace hysteron::fitting
