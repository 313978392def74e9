// The asymmetric MPI (FitModel::mpi_asym): two tanh envelopes (ascending, descending:
// 8 coefficients), q and n weights p_i >= 0 themselves on fixed thresholds, all refined
// by LM from branch-fit starts (starts.cpp: asym_starts).
#include "hysteron/error.hpp"
#include "kinds.hpp"

namespace hysteron::fitting {

namespace {

class MpiAsymKind final : public SlopeParametrization {
 public:
  bool handles(const FitOptions& o) const override { return o.model == FitModel::mpi_asym; }
  int num_parameters(const FitOptions& o) const override { return 8 + o.num_operators + 1; }
  // The envelopes take the scales; q and the p_i are unitless.
  double absorbed_factor(std::string_view name, double a, double b) const override {
    for (const char* side : {"ascending.", "descending."})
      if (const double f = tanh_absorbed_factor(name, side, a, b); f != 0.0) return f;
    return 1.0;
  }

 protected:
  Starts starts(const Data& d, const Ranges&, const FitOptions& o) const override {
    Starts st;
    asym_starts(d, o.num_operators, o, std::max(o.positivity_margin, 1e-12), st.layouts, st.theta);
    return st;
  }
  ModelParams model(const SlopeLayout& L, const double* th) const override {
    Structure<double> s;
    L.build(th, s);
    MpiAsymParams m;
    m.ascending = Envelope::tanh(th[0], th[1], th[2], th[3]);
    m.descending = Envelope::tanh(th[4], th[5], th[6], th[7]);
    m.q = s.q;
    m.r = s.r;
    m.p = s.p;
    return m;
  }
  // The model file's keys: ascending.c[0..3], descending.c[0..3], q, p[i].
  std::vector<std::string> names(const SlopeLayout& L) const override {
    std::vector<std::string> out;
    for (std::size_t i = 0; i < 4; ++i) out.push_back(indexed("ascending.c", i));
    for (std::size_t i = 0; i < 4; ++i) out.push_back(indexed("descending.c", i));
    out.push_back("q");
    for (std::size_t i = 0; i < L.r.size(); ++i) out.push_back(indexed("p", i));
    return out;
  }
  // theta holds the weights themselves: reported as they are.
  Eigen::MatrixXd report_map(const SlopeLayout& L) const override {
    return Eigen::MatrixXd::Identity(L.size(), L.size());
  }
};

}  // namespace

const Parametrization& mpi_asym_kind() {
  static const MpiAsymKind k;
  return k;
}

}  // namespace hysteron::fitting
