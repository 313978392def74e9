// The one place the experiments are registered (detail.hpp, experiment.hpp).
#include "detail.hpp"

namespace hysteron::experiment {

const std::vector<const Spec*>& registry() {
  static const std::vector<const Spec*> all{&gpi_pid_spec(), &mpi_openloop_spec(), &mpi_pwm_spec()};
  return all;
}

const Spec* find_spec(const std::string& name) noexcept {
  for (const Spec* s : registry())
    if (s->name == name) return s;
  return nullptr;
}

}  // namespace hysteron::experiment

namespace hysteron {

const std::vector<ExperimentInfo>& experiments() {
  static const std::vector<ExperimentInfo> all = [] {
    std::vector<ExperimentInfo> v;
    for (const auto* s : experiment::registry()) {
      ExperimentInfo i{s->name, s->title, s->summary, {}, s->published.source};
      for (const auto& var : s->variants) {
        i.variants.push_back(var.name);
        if (var.name == s->learning_on) i.variants.push_back("learning");
      }
      v.push_back(std::move(i));
    }
    return v;
  }();
  return all;
}

std::vector<std::string> experiment_names() {
  std::vector<std::string> names;
  for (const auto& e : experiments()) names.push_back(e.name);
  return names;
}

}  // namespace hysteron
