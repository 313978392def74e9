// The fit report's parameter names are the model file's keys: every reported
// parameter of every model kind reads the same value in io::model_to_json(report.model).
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "hysteron/identify.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/models.hpp"

using namespace hysteron;

namespace {

// The number at a report name in the model file: "key", "key[i]", "key.sub[i]".
std::optional<double> lookup(const nlohmann::json& j, const std::string& name) {
  const nlohmann::json* cur = &j;
  std::stringstream ss(name);
  std::string seg;
  while (std::getline(ss, seg, '.')) {
    const auto lb = seg.find('[');
    const std::string key = seg.substr(0, lb);
    if (!cur->is_object() || !cur->contains(key)) return std::nullopt;
    cur = &(*cur)[key];
    if (lb != std::string::npos) {
      const std::size_t idx = std::stoul(seg.substr(lb + 1));
      if (!cur->is_array() || idx >= cur->size()) return std::nullopt;
      cur = &(*cur)[idx];
    }
  }
  if (!cur->is_number()) return std::nullopt;
  return cur->get<double>();
}

// A hysteretic record in raw units with an input origin and scale and an output offset and gain.
void record(std::vector<double>& x, std::vector<double>& y) {
  PiParams truth;
  truth.q = 0.4;
  truth.r = {0.1, 0.25, 0.4, 0.6};
  truth.p = {0.3, 0.2, 0.15, 0.1};
  std::vector<double> xm;
  for (double a : {1.0, 0.8, 0.6, 0.9, 0.4, 1.0})
    for (int k = 0; k < 200; ++k) xm.push_back(a * std::sin(2 * M_PI * k / 200.0) + 0.1 * std::sin(0.37 * k));
  const auto ym = simulate_record(truth, xm);
  x.clear(), y.clear();
  for (std::size_t k = 0; k < xm.size(); ++k) {
    x.push_back(3.0 + 2.5 * xm[k]);
    y.push_back(-40.0 + 120.0 * (ym[k] + 0.05 * std::tanh(3 * xm[k])));
  }
}

}  // namespace

TEST(FitReportNames, EveryParameterIsAModelFileKeyWithTheSameValue) {
  std::vector<double> x, y;
  record(x, y);
  const std::map<std::string, double> units_default{
      {"input_origin", 0.0}, {"input_scale", 1.0}, {"output_offset", 0.0}, {"output_gain", 1.0}};
  struct Kind {
    FitModel model;
    bool free_weights;
  };
  for (const Kind k : {Kind{FitModel::pi, false}, Kind{FitModel::gpi, false}, Kind{FitModel::gpi, true},
                       Kind{FitModel::mpi_deadzone, false}, Kind{FitModel::mpi_asym, false}}) {
    FitOptions o;
    o.model = k.model;
    o.gpi_free_weights = k.free_weights;
    o.num_operators = 6;
    o.num_starts = 2;
    o.max_iterations = 60;
    o.poor_fit_ratio = 0;
    const FitReport r = fit(x, y, o);
    const std::string what = std::string(fit_model_name(k.model)) + (k.free_weights ? " (free weights)" : "");
    ASSERT_TRUE(r.status == FitStatus::converged || r.status == FitStatus::no_convergence) << what << "\n"
                                                                                            << r.full_report();
    ASSERT_FALSE(r.parameters.empty()) << what;
    const nlohmann::json j = io::model_to_json(r.model);
    for (const FitParameter& p : r.parameters) {
      std::optional<double> v = lookup(j, p.name);
      if (!v && units_default.count(p.name)) v = units_default.at(p.name);  // default keys are omitted
      ASSERT_TRUE(v.has_value()) << what << ": parameter " << p.name << " is not a model-file key\n" << j.dump();
      EXPECT_NEAR(*v, p.value, 1e-9 * std::max(1.0, std::abs(p.value))) << what << ": " << p.name;
    }
  }
}
