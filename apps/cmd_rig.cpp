// hysteron rig: a rig's parameters, every one with its unit, and what they imply at rest.
//
//   hysteron rig [FILE] [--json] [--out FULL.json]
// Without FILE the nominal rig (docs/plant.md). FILE is read as `--plant` reads it (unknown keys,
// wrong types and impossible values are errors naming the key); --out writes the complete rig,
// every key, as a template to edit.
#include <fmt/format.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "hysteron/error.hpp"
#include "hysteron/io/files.hpp"
#include "hysteron/plant.hpp"

namespace hysteron::cli {

namespace {

struct Options {
  std::string file, out;
  bool json = false;
};

std::string mm(double m) { return fmt::format("{:.1f} mm", m * 1e3); }

int run_rig(const Options& o) {
  // --out naming stdout (-, /dev/stdout, or the file stdout is redirected to) prints the rig's JSON alone
  const bool out_stdout = names_stdout(o.out);
  if (o.json && out_stdout)
    throw Error(fmt::format("--json and --out {} both print on stdout: give --out another file", o.out));
  io::check_output_files({{"--out", o.out}}, {{"FILE", o.file}});
  const PamRigParams p = o.file.empty() ? PamRigParams{} : load_rig_params(o.file);
  (void)PamRig(p, 1);  // what only the simulator checks: the sub-steps its dynamics need
  const RigStatics s = rig_statics(p);
  const std::string source = o.file.empty() ? std::string("the nominal rig") : o.file;
  if (!o.out.empty()) save_rig_params(p, out_stdout ? std::string("-") : o.out);
  if (!s.unusable.empty()) fmt::print(stderr, "rig: warning: the experiments refuse this rig: {}\n", s.unusable);
  if (!s.weak_return.empty()) fmt::print(stderr, "rig: warning: {}\n", s.weak_return);
  try {  // the experiments' 1 ms control period must be a whole number of rig steps
    control_steps(1e-3, p.simulation.dt, "the experiments' control period");
  } catch (const Error& e) {
    fmt::print(stderr, "rig: warning: the experiments refuse this rig: {}\n", e.what());
  }
  if (out_stdout) return exit_ok;  // stdout holds the rig's JSON alone
  if (!o.out.empty()) fmt::print(stderr, "rig: the complete rig written to {}\n", o.out);
  if (o.json) {
    const nlohmann::json j = {{"rig", source},
                              {"parameters", rig_params_to_json(p)},
                              {"units", rig_units_to_json()},
                              {"statics", rig_statics_to_json(s)}};
    fmt::print("{}\n", j.dump(2));
    return exit_ok;
  }
  const PamRigParams nominal;
  const auto defaults = rig_parameters(nominal);
  const auto params = rig_parameters(p);
  fmt::print("rig: {} (* differs from the nominal rig; docs/plant.md)\n", source);
  for (std::size_t i = 0; i < params.size(); ++i) {
    const RigParameter& r = params[i];
    fmt::print("  {:1}{:<32} {:>14.7g}{}\n", r.value != defaults[i].value ? "*" : "", r.path, r.value,
               r.unit == "-" ? "" : " " + r.unit);
  }
  fmt::print("at rest (P1-P5, the creep relaxed):\n");
  fmt::print("  stroke end (hard stop)        {}\n", mm(s.stroke_m));
  fmt::print("  return force                  {:.1f} N at rest, {:.1f} N at the stroke end (weight {:.1f} N, spring "
             "{:g} N + {:g} N/m x contraction)\n",
             s.return_force_rest_n, s.return_force_stroke_n, s.weight_n, p.load.spring_preload, p.load.spring_rate);
  if (std::isfinite(s.fall_speed_rest_m_s))
    fmt::print("  vented fall                   terminal speed {:.1f} mm/s at rest, {:.1f} mm/s at the stroke end (return "
               "force / load.damping; the creep's pull and the load's momentum add for a while)\n",
               s.fall_speed_rest_m_s * 1e3, s.fall_speed_stroke_m_s * 1e3);
  else
    fmt::print("  vented fall                   not limited by damping (load.damping = 0)\n");
  // after a hold at the top longer than the creep time (RigStatics::vented_stall_m); 1 um: the bisection's noise
  if (s.vented_stall_m > s.falling_m.front() + 1e-6)
    fmt::print("  vented, held at the top       falls to {} on the load's time scale, where the creep element (held at "
               "the top) pulls as hard as the return force, then at about {:.1f} mm/s as the creep relaxes (rest: "
               "{})\n",
               mm(s.vented_stall_m), s.creep_return_speed_m_s * 1e3, mm(s.falling_m.front()));
  else
    fmt::print("  vented, held at the top       falls to its rest, {}, on the load's time scale (the return force "
               "exceeds the creep element's pull)\n",
               mm(s.falling_m.front()));
  fmt::print("  pressure command limit        {:.3f} MPa with the regulator, {:.3f} MPa with the switching valves\n",
             s.regulator_limit_pa * 1e-6, s.valves_limit_pa * 1e-6);
  if (std::isfinite(s.lift_off_pa))
    fmt::print("  lift-off                      the rising branch contracts above {:.3f} MPa{}\n", s.lift_off_pa * 1e-6,
               s.lift_off_pa > s.regulator_limit_pa ? " (above the regulator path's command limit)" : "");
  else
    fmt::print("  lift-off                      none: the muscle cannot lift the load within the supply's pressure\n");
  fmt::print("  static contraction [mm]:\n    {:>9} {:>9} {:>9}\n", "P [MPa]", "rising", "falling");
  for (std::size_t i = 0; i < s.pressure_pa.size(); ++i)
    fmt::print("    {:>9.3f} {:>9.2f} {:>9.2f}\n", s.pressure_pa[i] * 1e-6, s.rising_m[i] * 1e3, s.falling_m[i] * 1e3);
  if (!s.rising_m.empty() && s.rising_m.back() >= s.stroke_m)
    fmt::print("note: the rising branch reaches the stroke end ({}) within the command limit: the muscle rests on its "
               "hard stop at the top\n",
               mm(s.stroke_m));
  return exit_ok;
}

}  // namespace

void add_rig(CLI::App& app, Action& action) {
  auto o = std::make_shared<Options>();
  CLI::App* sub = app.add_subcommand(
      "rig", "print a rig's parameters (every key, with its unit) and its static map; check a --plant file");
  sub->add_option("file", o->file,
                  "rig parameters (JSON, as --plant of experiment and sweep; default: the nominal rig)");
  sub->add_flag("--json", o->json, "print one JSON object (parameters, units, statics) instead of the text");
  sub->add_option("--out,-o", o->out,
                  "also write the complete rig, every key, as JSON (a template to edit; - prints it alone on stdout)");
  sub->callback([o, &action] { action = [o] { return run_rig(*o); }; });
}

}  // namespace hysteron::cli
