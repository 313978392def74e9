// hysteron::io: a model from its JSON text, stepped forward and inverted.
#include <hysteron/inverse.hpp>
#include <hysteron/io/model_file.hpp>

#include <cmath>
#include <cstdio>

int main() {
  const auto j = nlohmann::json::parse(R"({"model": "pi", "r": [0, 0.1, 0.2], "p": [1.0, 0.5, 0.25],
                                           "input_limits": [-1, 1]})");
  const hysteron::ModelParams params = hysteron::io::model_from_json(j, "consumer");
  hysteron::Model model(params);
  hysteron::Inverse inverse(params);
  double worst = 0;
  for (int k = 0; k < 1000; ++k) {
    const double x = 0.8 * std::sin(0.02 * k);
    worst = std::fmax(worst, std::fabs(inverse.step(model.step(x)) - x));
  }
  std::printf("consumer io: max round-trip error %.3g\n", worst);
  return worst < 1e-12 ? 0 : 1;
}
