// A rig that changed after its identification (docs/plant.md, "Identified on the nominal
// rig"): gpi-pid identified and tuned on the nominal rig, then tracking on the same rig with the
// load damping halved (400 -> 200 N s/m), as `hysteron sweep gpi-pid --vary load.damping=200
// --identify-on-base`; beside it the same change re-identified and re-tuned on the changed rig.
// Prints the RMS error of each variant kind. Fails unless, on the changed rig not re-tuned, the
// learning loop ends below the compensated loop and below the baseline, the compensated loop
// (whose limit-cycle guard cuts the gains that ring there, docs/control.md section 2) ends below
// the baseline too, and re-tuning brings the compensated loop below its baseline.
#include <fmt/format.h>

#include <map>
#include <string>

#include <hysteron/sweep.hpp>

namespace {

// RMS error [mm] of each variant kind on the changed rig (the sweep's variant 1).
std::map<std::string, double> rms(const hysteron::SweepResult& r) {
  std::map<std::string, double> out;
  for (const auto& t : r.run(0, 1).runs) out[t.kind] = t.errors.rms_error_mm;
  return out;
}

}  // namespace

int main() {
  hysteron::SweepOptions o;
  o.experiments = {"gpi-pid"};
  o.variants = hysteron::parse_vary("load.damping=200");
  o.learning_periods = 4;
  o.jobs = 2;
  o.identify_on_base = true;  // tuned on the nominal rig
  const hysteron::SweepResult changed = hysteron::run_sweep(o);
  o.identify_on_base = false;  // tuned on the changed rig
  const hysteron::SweepResult retuned = hysteron::run_sweep(o);
  if (!changed.run(0, 1).ok || !retuned.run(0, 1).ok) {
    fmt::print("FAIL: a run failed: {}{}\n", changed.run(0, 1).error, retuned.run(0, 1).error);
    return 1;
  }
  auto a = rms(changed), b = rms(retuned);
  fmt::print("{:<12} {:>13} {:>9}   RMS [mm], load damping 200 N s/m\n", "kind", "not re-tuned", "re-tuned");
  for (const auto& [kind, v] : a) fmt::print("{:<12} {:>13.3f} {:>9.3f}\n", kind, v, b[kind]);
  const bool ok = a["learning"] < a["compensated"] && a["learning"] < a["baseline"] &&
                  a["compensated"] < a["baseline"] && b["compensated"] < b["baseline"];
  if (!ok) {
    fmt::print("FAIL: expected learning below compensated and baseline on the changed rig, the compensated loop "
               "below its baseline there, and the re-tuned compensated loop below its baseline\n");
    return 1;
  }
  return 0;
}
