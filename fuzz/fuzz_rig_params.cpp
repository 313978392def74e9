// libFuzzer target: the rig-parameter loader (strict JSON + rig_params_from_json). Accepted
// parameters must pass validate() and survive a JSON round trip unchanged. Only
// hysteron::Error may escape.
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "hysteron/error.hpp"
#include "hysteron/io/model_file.hpp"
#include "hysteron/plant.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  hysteron::PamRigParams p;
  try {
    p = hysteron::rig_params_from_json(hysteron::io::parse_json(text, "fuzz.json"), "fuzz.json");
  } catch (const hysteron::Error&) {
    return 0;
  }
  const nlohmann::json j = hysteron::rig_params_to_json(p);
  try {
    hysteron::validate(p, "fuzz.json");
    const hysteron::PamRigParams q = hysteron::rig_params_from_json(j, "round-trip");
    if (hysteron::rig_params_to_json(q) != j) std::abort();
  } catch (const hysteron::Error&) {
    std::abort();  // accepted parameters must be valid and written in a form that reads back
  }
  return 0;
}
