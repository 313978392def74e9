// libFuzzer target: the model-file loader (strict JSON + model_from_json). An accepted model
// must build, run a few samples and survive a write/read round trip unchanged. Only
// hysteron::Error may escape.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "hysteron/error.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/models.hpp"

namespace io = hysteron::io;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  hysteron::ModelParams params;
  try {
    params = io::model_from_json(io::parse_json(text, "fuzz.json"), "fuzz.json");
  } catch (const hysteron::Error&) {
    return 0;
  }
  const nlohmann::json j = io::model_to_json(params);
  hysteron::ModelParams again;
  try {
    again = io::model_from_json(io::parse_json(j.dump(), "round-trip"), "round-trip");
  } catch (const hysteron::Error&) {
    std::abort();  // a model the loader accepted must be written in a form it accepts
  }
  if (io::model_to_json(again) != j) std::abort();
  hysteron::Model m(params);
  for (const double x : {0.0, 0.5, 1.0, -1.0, 0.25}) (void)m.step(x);
  return 0;
}
