// The simulated DMSP-20-500 rig (plant.hpp).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <filesystem>
#include <limits>
#include <fstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "alloc_counter.hpp"
#include "hysteron/plant.hpp"
#include "hysteron/signals.hpp"

using namespace hysteron;

namespace {

// Runs a sampled regulator command [MPa] (one sample per rig step).
std::vector<RigOutputs> run_regulator(PamRig& rig, const std::vector<double>& u) {
  std::vector<RigOutputs> out;
  out.reserve(u.size());
  for (double c : u) out.push_back(rig.step({c, 0.0, Actuation::regulator}));
  return out;
}

// Contraction where the true pressure first crosses p upwards, and last crosses it downwards.
struct Crossing {
  double up = NAN, down = NAN;
};
Crossing crossings(const std::vector<RigOutputs>& y, double p) {
  Crossing c;
  for (std::size_t k = 1; k < y.size(); ++k) {
    if (std::isnan(c.up) && y[k - 1].pressure < p && y[k].pressure >= p) c.up = y[k].contraction;
    if (y[k - 1].pressure > p && y[k].pressure <= p) c.down = y[k].contraction;
  }
  return c;
}

std::string error_of(const auto& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(PlantPhysics, ForceMapAndVolume) {
  const MuscleParams m;
  EXPECT_NEAR(festo_force(m, 620e3, 0.0), 1326.0, 1e-9);  // P* = 1, e = 0: F = F620
  EXPECT_EQ(festo_force(m, 0.0, 0.05), 0.0);                // vented: no pull
  // Hand value: P = 300 kPa, eps = 0.1 -> e = 0.392157.
  const double e = 0.1 / 0.255;
  const double f = 1326.0 * (0.2579 * (std::exp(-6.477 * e) - 1.0) + 300.0 / 620.0 * std::exp(-1.321 * e * e));
  EXPECT_NEAR(festo_force(m, 300e3, 0.1), f, 1e-9);
  EXPECT_NEAR(f, 208.65, 0.01);
  // pam-plant.md: about 187 / 292 / 346 cm^3 at eps = 0 / 0.125 / 0.25 (+ dead volume).
  EXPECT_NEAR((muscle_volume(m, 0.0) - m.dead_volume) * 1e6, 187.0, 1.0);
  EXPECT_NEAR((muscle_volume(m, 0.125) - m.dead_volume) * 1e6, 292.0, 1.0);
  EXPECT_NEAR((muscle_volume(m, 0.25) - m.dead_volume) * 1e6, 346.0, 1.0);
  const double h = 1e-6;
  EXPECT_NEAR(muscle_volume_derivative(m, 0.1),
              (muscle_volume(m, 0.1 + h) - muscle_volume(m, 0.1 - h)) / (2 * h), 1e-9);
}

TEST(PlantPhysics, Iso6358Flow) {
  const AirParams air;
  const double C = 4e-9, b = 0.38;
  const double choked = C * air.rho0 * 7e5;
  EXPECT_NEAR(iso6358_mass_flow(C, b, 7e5, 1e5, air.temperature, air), choked, 1e-15);
  EXPECT_EQ(iso6358_mass_flow(C, b, 3e5, 3e5, air.temperature, air), 0.0);
  EXPECT_EQ(iso6358_mass_flow(C, b, 3e5, 4e5, air.temperature, air), 0.0);
  const double r = 0.7, q = (r - b) / (1 - b);
  EXPECT_NEAR(iso6358_mass_flow(C, b, 5e5, r * 5e5, air.temperature, air),
              C * air.rho0 * 5e5 * std::sqrt(1 - q * q), 1e-15);
  // Continuous at the switch to the linear law (p2/p1 = 0.999).
  const double below = iso6358_mass_flow(C, b, 5e5, 0.999 * 5e5 - 1e-6, air.temperature, air);
  const double above = iso6358_mass_flow(C, b, 5e5, 0.999 * 5e5 + 1e-6, air.temperature, air);
  EXPECT_NEAR(below, above, 1e-3 * below);
}

TEST(PlantPhysics, NominalLoadReachesTheGpiSinusoid) {
  // Eq. 18 / Table 4: contraction 5..95 mm must be reachable within 0..0.6 MPa.
  const PamRigParams p;
  EXPECT_EQ(static_contraction(p, 0.0), 0.0);
  EXPECT_GT(static_contraction(p, 0.6e6, +1.0), 0.095);  // even on the rising branch
  EXPECT_LT(static_contraction(p, 0.6e6, -1.0), 0.130);
}

TEST(PamRig, DeterministicPerSeed) {
  const auto u = gpi_identification_pressure(1e-4);
  const std::vector<double> part(u.begin(), u.begin() + 20000);  // 2 s
  PamRig a(PamRigParams{}, 42), b(PamRigParams{}, 42), c(PamRigParams{}, 43);
  const auto ya = run_regulator(a, part), yb = run_regulator(b, part), yc = run_regulator(c, part);
  bool differs = false;
  for (std::size_t k = 0; k < ya.size(); ++k) {
    ASSERT_EQ(ya[k].contraction_measured, yb[k].contraction_measured) << k;
    ASSERT_EQ(ya[k].pressure_measured, yb[k].pressure_measured) << k;
    ASSERT_EQ(ya[k].contraction, yb[k].contraction) << k;
    differs = differs || ya[k].pressure_measured != yc[k].pressure_measured ||
              ya[k].contraction_measured != yc[k].contraction_measured;
    EXPECT_EQ(ya[k].contraction, yc[k].contraction);  // noise does not touch the physics
  }
  EXPECT_TRUE(differs);
  // reset() replays the same series.
  a.reset();
  const auto ya2 = run_regulator(a, part);
  for (std::size_t k = 0; k < ya.size(); k += 997) EXPECT_EQ(ya[k].pressure_measured, ya2[k].pressure_measured);
}

TEST(PamRig, StaticEquilibriumMatchesForceMap) {
  PamRig rig(PamRigParams{}, 1);
  // Ramp to 0.4 MPa in 2 s, then hold for 40 s (creep relaxes with tau_c = 4 s).
  std::vector<double> u;
  for (int k = 0; k < 420000; ++k) u.push_back(std::min(0.4, 0.2 * k * 1e-4));
  const auto y = run_regulator(rig, u);
  const double p = y.back().pressure;
  EXPECT_NEAR(p, 0.4e6, 50.0);                  // the regulator holds its setpoint
  EXPECT_NEAR(rig.state().velocity, 0.0, 1e-6);
  const double x_eq = static_contraction(rig.params(), p, rig.state().bouc_wen);
  EXPECT_NEAR(y.back().contraction, x_eq, 1e-5) << "z = " << rig.state().bouc_wen;
  EXPECT_GT(rig.state().bouc_wen, 0.5);  // reached on the shortening branch
  // And the force balance itself: F(P - dP_h z, eps) = m g.
  const auto& prm = rig.params();
  const double f = festo_force(prm.muscle, p - prm.hysteresis.pressure_band * rig.state().bouc_wen,
                               y.back().contraction / prm.muscle.rest_length);
  EXPECT_NEAR(f, prm.load.mass * prm.load.gravity, 0.05);
}

// A horizontal rig (no weight) with a return spring: the spring, not gravity, balances the
// muscle (P5), and it extends the vented muscle again.
TEST(PamRig, AReturnSpringBalancesAHorizontalRig) {
  PamRigParams prm;
  prm.load.gravity = 0.0;
  prm.load.spring_preload = 150.0;  // [N]
  prm.load.spring_rate = 3000.0;    // [N/m]
  PamRig rig(prm, 1);
  std::vector<double> u;
  for (int k = 0; k < 300000; ++k) u.push_back(std::min(0.4, 0.2 * k * 1e-4));  // to 0.4 MPa, hold 28 s
  const auto y = run_regulator(rig, u);
  const double p = y.back().pressure, x = y.back().contraction;
  EXPECT_NEAR(rig.state().velocity, 0.0, 1e-6);
  EXPECT_GT(x, 0.01);
  const double f = festo_force(prm.muscle, p - prm.hysteresis.pressure_band * rig.state().bouc_wen,
                               x / prm.muscle.rest_length);
  EXPECT_NEAR(f, 150.0 + 3000.0 * x, 0.1);  // the spring's force at x, not a weight
  EXPECT_NEAR(x, static_contraction(prm, p, rig.state().bouc_wen), 1e-5);
  // the same rig without the spring would not hold the load there: it contracts to the stop
  PamRigParams free = prm;
  free.load.spring_preload = free.load.spring_rate = 0.0;
  EXPECT_NEAR(static_contraction(free, p, rig.state().bouc_wen), free.muscle.max_contraction * free.muscle.rest_length,
              1e-9);
  // vented, the spring extends the muscle again, to where the vented muscle's force meets it
  const auto back = run_regulator(rig, std::vector<double>(100000, 0.0));
  EXPECT_LT(back.back().contraction, 0.25 * x);
  EXPECT_NEAR(back.back().contraction, static_contraction(prm, back.back().pressure, rig.state().bouc_wen), 2e-4);
  // written and read back
  const PamRigParams again = rig_params_from_json(rig_params_to_json(prm), "rig");
  EXPECT_EQ(again.load.spring_rate, 3000.0);
  EXPECT_EQ(again.load.spring_preload, 150.0);
  prm.load.spring_rate = -1.0;
  EXPECT_THROW(validate(prm), Error);
}

// A weak return force (a horizontal rig, a 1 N preload): held at the top of its reach for 20 s (5
// creep times: the creep element relaxed, x_c at the top) and vented, the muscle pulls nothing up
// there (F(dP_h, eps) = 0, checked), so it falls only to where the creep element's pull meets the
// preload, top - F_s0 / k_c = top - 6.7 mm, then crawls as the creep relaxes, at F_s0 / (c + k_c tau_c)
// = 1 mm/s (P4: a spring k_c in series with a dashpot k_c tau_c, in parallel with the damping c).
// The simulated rig does so: still in the upper half of its reach 10 s after venting (the static
// map, the creep relaxed, puts its rest at 1.9 mm), and rig_statics warns. Light but usable rigs
// (5 kg; gravity 0 with a 50 or 200 N preload; 100 N and 2000 N/m) are back below a tenth of their
// reach 2 s after venting, as the nominal rig, and are not warned.
TEST(PamRig, AWeakReturnForceLeavesTheVentedMuscleToTheCreep) {
  const auto hold_and_vent = [](const PamRigParams& prm, int vented_steps) {
    PamRig rig(prm, 1);
    const double top = pressure_command_limit(prm, Actuation::regulator) * 1e-6;  // [MPa]
    for (int k = 0; k < 200000; ++k) rig.step({top, 0.0, Actuation::regulator});
    for (int k = 0; k < vented_steps; ++k) rig.step({0.0, 0.0, Actuation::regulator});
    return rig.state().contraction;
  };
  PamRigParams weak;
  weak.load.gravity = 0.0;
  weak.load.spring_preload = 1.0;  // [N]
  const RigStatics s = rig_statics(weak);
  const double top = s.rising_m.back(), k_c = weak.hysteresis.creep_stiffness;
  EXPECT_EQ(festo_force(weak.muscle, weak.hysteresis.pressure_band, (top - 1.0 / k_c) / weak.muscle.rest_length), 0.0);
  EXPECT_NEAR(s.vented_stall_m, top - 1.0 / k_c, 1e-9);
  EXPECT_NEAR(s.creep_return_speed_m_s, 1.0 / (weak.load.damping + k_c * weak.hysteresis.creep_time), 1e-12);
  EXPECT_LT(s.falling_m.front(), 0.02 * top);  // what the static map shows: a rest near 0
  EXPECT_NE(s.weak_return.find("the return force is weak against the creep element"), std::string::npos)
      << s.weak_return;
  EXPECT_NE(s.weak_return.find("rig.load.spring_preload = 1 N"), std::string::npos) << s.weak_return;
  EXPECT_EQ(rig_statics_to_json(s).at("weak_return"), s.weak_return);
  EXPECT_GT(hold_and_vent(weak, 100000), 0.5 * top);

  std::vector<PamRigParams> usable(5);
  usable[1].load.mass = 5.0;
  for (int i : {2, 3, 4}) usable[i].load.gravity = 0.0;
  usable[2].load.spring_preload = 50.0;
  usable[3].load.spring_preload = 200.0;
  usable[4].load.spring_preload = 100.0;
  usable[4].load.spring_rate = 2000.0;
  for (const PamRigParams& prm : usable) {
    SCOPED_TRACE(rig_params_to_json(prm).at("load").dump());
    const RigStatics u = rig_statics(prm);
    EXPECT_EQ(u.weak_return, "");
    EXPECT_LT(hold_and_vent(prm, 20000), 0.1 * u.rising_m.back());
  }

  // nothing resists the fall (no damping, no creep stiffness) and no force at the stall (a
  // spring without preload, vented at rest): the crawl speed is infinite, as the fall speeds,
  // not 0 / 0 = NaN, and null in JSON
  PamRigParams free;
  free.load.gravity = 0.0;
  free.load.damping = 0.0;
  free.load.spring_rate = 2000.0;
  free.hysteresis.creep_stiffness = 0.0;
  free.hysteresis.pressure_band = 0.0;
  const RigStatics f = rig_statics(free);
  EXPECT_TRUE(std::isinf(f.creep_return_speed_m_s)) << f.creep_return_speed_m_s;
  EXPECT_TRUE(rig_statics_to_json(f).at("creep_return_speed_m_s").is_null());
}

// rig_statics (hysteron rig) against the force balance P1-P5 written out here: at the lift-off
// pressure the rising branch's force at rest meets the return force; every contraction of the
// table between the stops balances the force map against the weight and the spring.
TEST(PamRig, StaticsBalanceTheForceMapAgainstTheReturnForce) {
  for (const bool spring : {false, true}) {
    PamRigParams prm;
    if (spring) {
      prm.load.gravity = 0.0;
      prm.load.spring_preload = 120.0;
      prm.load.spring_rate = 2500.0;
    }
    SCOPED_TRACE(spring);
    const RigStatics s = rig_statics(prm);
    const auto& m = prm.muscle;
    const double rest = prm.load.mass * prm.load.gravity + prm.load.spring_preload;
    EXPECT_DOUBLE_EQ(s.return_force_rest_n, rest);
    EXPECT_DOUBLE_EQ(s.fall_speed_rest_m_s, rest / prm.load.damping);
    EXPECT_DOUBLE_EQ(s.fall_speed_stroke_m_s,
                     (rest + prm.load.spring_rate * m.max_contraction * m.rest_length) / prm.load.damping);
    EXPECT_DOUBLE_EQ(s.stroke_m, m.max_contraction * m.rest_length);
    const double band = prm.hysteresis.pressure_band;  // its slope is 0 on this rig
    EXPECT_NEAR(festo_force(m, s.lift_off_pa - band, 0.0), rest, 1e-3);
    ASSERT_GE(s.pressure_pa.size(), 7u);
    EXPECT_EQ(s.pressure_pa.back(), 6e5);
    int interior = 0;
    for (std::size_t i = 0; i < s.pressure_pa.size(); ++i) {
      for (const double z : {1.0, -1.0}) {
        const double x = z > 0 ? s.rising_m[i] : s.falling_m[i];
        if (!(x > 1e-6 && x < s.stroke_m - 1e-6)) continue;
        ++interior;
        const double f = festo_force(m, s.pressure_pa[i] - band * z, x / m.rest_length);
        EXPECT_NEAR(f, prm.load.mass * prm.load.gravity + prm.load.spring_preload + prm.load.spring_rate * x, 1e-3)
            << s.pressure_pa[i] << " " << z;
      }
      EXPECT_LE(s.rising_m[i], s.falling_m[i]);  // the rising branch lies below the falling one
    }
    EXPECT_GE(interior, 8);
  }
  // every parameter has a unit, and the list is the JSON form's
  const auto list = rig_parameters(PamRigParams{});
  const nlohmann::json j = rig_params_to_json(PamRigParams{});
  std::size_t keys = 0;
  for (const auto& [section, body] : j.items()) keys += body.size();
  EXPECT_EQ(list.size(), keys);
  for (const RigParameter& r : list) {
    EXPECT_FALSE(r.unit.empty()) << r.path;
    const auto dot = r.path.find('.');
    EXPECT_EQ(j.at(r.path.substr(0, dot)).at(r.path.substr(dot + 1)).get<double>(), r.value) << r.path;
  }
}

TEST(PamRig, LengthPressureLoopIsWideAndAsymmetric) {
  PamRig rig(PamRigParams{}, 7);
  const auto u = gpi_identification_pressure(1e-4);
  const std::vector<double> major(u.begin(), u.begin() + 50000);  // 0 -> 0.6 -> 0 MPa, 0.2 Hz
  const auto y = run_regulator(rig, major);
  double x_max = 0.0;
  for (const auto& o : y) x_max = std::max(x_max, o.contraction);
  EXPECT_GT(x_max, 0.090);
  EXPECT_LT(x_max, 0.130);
  std::vector<double> width;
  for (double p : {0.2e6, 0.3e6, 0.4e6, 0.5e6}) {
    const auto c = crossings(y, p);
    ASSERT_FALSE(std::isnan(c.up) || std::isnan(c.down)) << p;
    width.push_back(c.down - c.up);
    EXPECT_GT(c.down - c.up, 0.002) << "loop width at " << p << " Pa";
  }
  // Asymmetric: a point-symmetric (classical PI) loop has equal widths at pressures
  // symmetric about its centre (0.3 MPa): here 0.2 vs 0.4 MPa.
  EXPECT_GT(std::abs(width[0] - width[2]), 0.002);
  EXPECT_GT(width[1], 1.5 * width[3]);  // loops narrow towards high pressure
  // Back at 0 MPa the muscle rests on its stop at full length.
  EXPECT_NEAR(y.back().contraction, 0.0, 1e-3);
}

TEST(PamRig, ChamberFillsTowardSupplyAndVents) {
  const PamRigParams prm;
  const double supply_gauge = prm.air.supply_pressure - prm.air.atmospheric_pressure;
  PamRig rig(prm, 3);
  double p_max = 0.0;
  for (int k = 0; k < 40000; ++k) p_max = std::max(p_max, rig.step({0.0, 1.0, Actuation::switching_valves}).pressure);
  EXPECT_GT(rig.last_outputs().pressure, 0.97 * supply_gauge);
  EXPECT_LE(p_max, supply_gauge + 1e3);  // open to the supply: no overshoot beyond rounding
  EXPECT_TRUE(rig.last_outputs().inlet_open);
  for (int k = 0; k < 60000; ++k) rig.step({0.0, -1.0, Actuation::switching_valves});
  EXPECT_LT(rig.last_outputs().pressure, 3e3);
  EXPECT_GE(rig.last_outputs().pressure, 0.0);
  EXPECT_TRUE(rig.last_outputs().exhaust_open);
  // Regulator asked for its full 10 bar range: limited by the 6 bar (gauge) supply.
  rig.reset();
  for (int k = 0; k < 40000; ++k) p_max = std::max(p_max, rig.step({1.0, 0.0, Actuation::regulator}).pressure);
  EXPECT_GT(rig.last_outputs().pressure, 0.97 * supply_gauge);
  EXPECT_LE(rig.last_outputs().pressure, supply_gauge);
  // The rebounding load compresses the air momentarily above the supply (the
  // orifice limits the backflow): a few percent at most.
  EXPECT_LE(p_max, supply_gauge + 0.03 * prm.air.supply_pressure);
  rig.check();
}

TEST(PamRig, ZeroDutyHoldsPressure) {
  PamRig rig(PamRigParams{}, 5);
  rig.reset_at_pressure(0.3e6);
  for (int k = 0; k < 20000; ++k) rig.step({0.0, 0.0, Actuation::switching_valves});
  EXPECT_NEAR(rig.last_outputs().pressure, 0.3e6, 1.0);
  EXPECT_FALSE(rig.last_outputs().inlet_open || rig.last_outputs().exhaust_open);
  // A positive duty raises it, a negative one lowers it.
  for (int k = 0; k < 2000; ++k) rig.step({0.0, 0.3, Actuation::switching_valves});
  const double up = rig.last_outputs().pressure;
  EXPECT_GT(up, 0.31e6);
  for (int k = 0; k < 2000; ++k) rig.step({0.0, -0.3, Actuation::switching_valves});
  EXPECT_LT(rig.last_outputs().pressure, up - 10e3);
}

TEST(PamRig, PwmEdgesInsideTheStepAreExact) {
  // Edges at odd times (333 Hz, 1.23 / 0.87 ms delays): the step size must not matter.
  auto run = [](double dt) {
    PamRigParams p;
    p.simulation.dt = dt;
    p.valves.pwm_frequency = 333.0;
    p.valves.on_delay = 1.23e-3;
    p.valves.off_delay = 0.87e-3;
    p.sensors.pressure_noise = 0.0;
    PamRig rig(p, 1);
    rig.reset_at_pressure(0.2e6);
    const auto n = static_cast<int>(std::lround(0.15 / dt));
    for (int k = 0; k < n; ++k) rig.step({0.0, 0.37, Actuation::switching_valves});
    return rig.last_outputs().pressure;
  };
  const double coarse = run(1e-4), fine = run(1e-5);
  EXPECT_GT(coarse, 0.23e6);
  EXPECT_NEAR(coarse, fine, 1e-6 * fine);  // measured: identical to 1e-3 Pa
}

TEST(PamRig, NonFiniteInputsAreHeld) {
  PamRig rig(PamRigParams{}, 1);
  for (int k = 0; k < 100; ++k) rig.step({0.3, 0.0, Actuation::regulator});
  rig.step({NAN, NAN, Actuation::regulator});
  EXPECT_EQ(rig.input_faults(), 2u);
  EXPECT_TRUE(rig.ok());
}

TEST(PamRig, DivergenceIsReportedWithTime) {
  PamRig rig(PamRigParams{}, 1);
  for (int k = 0; k < 10; ++k) rig.step({0.2, 0.0, Actuation::regulator});
  RigState s = rig.state();
  s.pressure = NAN;
  rig.set_state(s);
  const auto y = rig.step({0.2, 0.0, Actuation::regulator});
  EXPECT_FALSE(y.ok);
  EXPECT_FALSE(rig.ok());
  const std::string msg = error_of([&] { rig.check(); });
  EXPECT_NE(msg.find("t = 0.001100 s"), std::string::npos) << msg;
  EXPECT_NE(msg.find("non-finite"), std::string::npos) << msg;
  // The rig stays frozen; run() refuses to continue.
  EXPECT_EQ(rig.step({0.2, 0.0, Actuation::regulator}).time, y.time);
  EXPECT_THROW(rig.run(1.0, 0.0, [](const RigOutputs&) { return RigInputs{}; }), Error);

  // Pressure above the supply (a corrupted state) is caught inside run().
  PamRig rig2(PamRigParams{}, 1);
  RigState s2 = rig2.state();
  s2.pressure = 5.0 * rig2.params().air.supply_pressure;
  rig2.set_state(s2);
  const std::string msg2 = error_of([&] { rig2.run(1.0, 1e-3, [](const RigOutputs&) { return RigInputs{}; }); });
  EXPECT_NE(msg2.find("pressure above the supply"), std::string::npos) << msg2;
  EXPECT_NE(msg2.find("t = 0.000100 s"), std::string::npos) << msg2;
}

TEST(PamRig, ExcessiveStiffnessRejectedAtConstruction) {
  PamRigParams p;
  p.valves.sonic_conductance = 1e-3;  // absurd: a pipe the size of a barn door
  const std::string msg = error_of([&] { PamRig rig(p, 1); });
  EXPECT_NE(msg.find("max_substeps"), std::string::npos) << msg;
  // the load's rate too: 0.5 g on a 20 kN s/m guide needs 4001 sub-steps, refused by name
  PamRigParams light;
  light.load.mass = 5e-4;
  light.load.damping = 2e4;
  const std::string m2 = error_of([&] { PamRig rig(light, 1); });
  EXPECT_NE(m2.find("load.damping c = 2e+04"), std::string::npos) << m2;
  EXPECT_NE(m2.find("max_substeps"), std::string::npos) << m2;
  // and a return spring far too stiff for the step (1e14 N/m on 20 kg), named with its rate
  PamRigParams stiff;
  stiff.load.spring_rate = 1e14;
  const std::string m3 = error_of([&] { PamRig rig(stiff, 1); });
  EXPECT_NE(m3.find("load.spring_rate 1e+14"), std::string::npos) << m3;
  EXPECT_NE(m3.find("a softer return spring"), std::string::npos) << m3;
}

// A light load on a heavily damped guide (0.5 kg, 20 kN s/m: c / m = 4e4 1/s, beyond RK4's
// stability at one step of 0.1 ms) is integrated with enough sub-steps; it diverged at run time
// ("non-positive absolute pressure") before 2026-11-29.
TEST(PamRig, StiffLoadGetsItsSubSteps) {
  PamRigParams p;
  p.load.mass = 0.5;
  p.load.damping = 2e4;
  PamRig rig(p, 1);
  for (int k = 0; k < 20000; ++k) rig.step({0.4, 0.0, Actuation::regulator});  // 2 s at 0.4 MPa
  ASSERT_TRUE(rig.ok());
  EXPECT_NO_THROW(rig.check());
  EXPECT_GT(rig.state().contraction, 0.01);  // it moves, slowly: c / k of about 1 s
  // the nominal rig's sub-steps are the air's alone (its load's rate is 50 1/s)
  PamRig nominal(PamRigParams{}, 1);
  EXPECT_TRUE(nominal.ok());
}

TEST(PamRig, StepAndRunDoNotAllocate) {
  PamRig rig(PamRigParams{}, 1);
  const std::size_t before = hysteron_test::allocations();
  for (int k = 0; k < 5000; ++k) rig.step({0.3, 0.0, Actuation::regulator});
  for (int k = 0; k < 5000; ++k) rig.step({0.0, 0.5, Actuation::switching_valves});
  double sum = 0.0;
  rig.run(0.5, 1e-3, [](const RigOutputs& y) { return RigInputs{0.3 + 0.0 * y.time, 0.0, Actuation::regulator}; },
          [&](const RigInputs&, const RigOutputs& y) { sum += y.contraction; });
  EXPECT_EQ(hysteron_test::allocations(), before);
  EXPECT_GT(sum, 0.0);
}


// run() without an observer skips the sensor outputs of the steps between control samples;
// the controller must see bit for bit what it sees with an observer (which measures every
// step), with the regulator and with the valves, a control period of 10 and of 7 rig steps
// (one that does not divide the duration) and a sensor filter.
TEST(PamRig, AControlPeriodMustBeAWholeNumberOfRigSteps) {
  EXPECT_EQ(control_steps(1e-3, 1e-4, "x"), 10);
  EXPECT_EQ(control_steps(1e-3, 5e-5, "x"), 20);
  EXPECT_EQ(control_steps(7e-4, 1e-4, "x"), 7);
  EXPECT_EQ(control_steps(1e-4, 1e-4, "x"), 1);
  // 1e-3 / 9.52e-5 = 10.504 steps, rounded to 11: the loop ran every 11 x 9.52e-5 = 1.0472 ms. The dts
  // dividing 1 ms either side: 1e-3/10 = 1e-4 (4.8e-6 s away) and 1e-3/11 = 9.0909e-5 (4.29e-6 s away), the nearer
  const std::string msg = error_of([] { control_steps(1e-3, 9.52e-5, "experiment: rig"); });
  EXPECT_EQ(msg.rfind("experiment: rig: control_period = 0.001 s", 0), 0u) << msg;
  EXPECT_NE(msg.find("simulation.dt = 9.52e-05 s"), std::string::npos) << msg;
  // the suggested dt, as printed, is accepted (printed to 6 digits, 9.09091e-05, it was refused in turn)
  const std::string near = "nearest dt that divides it is ";
  const std::size_t at = msg.find(near);
  ASSERT_NE(at, std::string::npos) << msg;
  const double suggested = std::stod(msg.substr(at + near.size()));
  EXPECT_NEAR(suggested, 9.0909e-5, 1e-9) << msg;
  EXPECT_EQ(control_steps(1e-3, suggested, "x"), 11) << msg;
  EXPECT_NE(msg.find(" s (11 steps)", at), std::string::npos) << msg;
  // 1e-3 / 1.2e-4 = 8.33: 1e-3/8 = 1.25e-4 (5e-6 away) is nearer than 1e-3/9 = 1.111e-4 (8.9e-6 away)
  EXPECT_NE(error_of([] { control_steps(1e-3, 1.2e-4, "x"); }).find("is 0.000125 s (8 steps)"), std::string::npos);
  // shorter than dt: no longer run every step, refused (the nearest dt is the period itself)
  EXPECT_NE(error_of([] { control_steps(5e-5, 1e-4, "x"); }).find("is 5e-05 s (1 steps)"), std::string::npos);
  for (double bad : {0.0, -1e-3, std::nan(""), std::numeric_limits<double>::infinity(), 1e9})
    EXPECT_NE(error_of([bad] { control_steps(bad, 1e-4, "x"); }).find("whole multiple"), std::string::npos) << bad;

  // run() refuses such a period before the first step (it ran every 11 steps, 1.0472 ms)
  PamRigParams p;
  p.simulation.dt = 9.52e-5;
  PamRig rig(p, 1);
  int calls = 0;
  const std::string run_msg = error_of([&] {
    rig.run(0.01, 1e-3, [&](const RigOutputs&) { ++calls; return RigInputs{0.2, 0.0, Actuation::regulator}; });
  });
  EXPECT_NE(run_msg.find("PamRig::run: control_period = 0.001 s is not a whole multiple"), std::string::npos)
      << run_msg;
  EXPECT_EQ(calls, 0);
  EXPECT_EQ(rig.time(), 0.0);
}

TEST(PamRig, RunWithoutObserverSeesWhatRunWithObserverSees) {
  PamRigParams p;
  p.sensors.pressure_time_constant = 2e-3;
  for (const Actuation mode : {Actuation::regulator, Actuation::switching_valves}) {
    for (const double period : {1e-3, 7e-4}) {
      auto law = [&](std::vector<RigOutputs>& seen) {
        return [&seen, mode](const RigOutputs& y) {
          seen.push_back(y);
          const double t = y.time, u = 0.25 + 0.2 * std::sin(6.0 * t);
          return mode == Actuation::regulator ? RigInputs{u, 0.0, mode}
                                              : RigInputs{0.0, std::sin(9.0 * t + 40.0 * y.contraction_measured), mode};
        };
      };
      std::vector<RigOutputs> a, b;
      PamRig ra(p, 7), rb(p, 7);
      std::size_t observed = 0;
      const RigOutputs la = ra.run(0.8, period, law(a), [&](const RigInputs&, const RigOutputs&) { ++observed; });
      const RigOutputs lb = rb.run(0.8, period, law(b));
      ASSERT_EQ(observed, 8000u);
      ASSERT_EQ(a.size(), b.size());
      ASSERT_GT(a.size(), 100u);
      for (std::size_t i = 0; i < a.size(); ++i) {
        ASSERT_EQ(a[i].time, b[i].time) << i;
        ASSERT_EQ(a[i].contraction_measured, b[i].contraction_measured) << i;
        ASSERT_EQ(a[i].pressure_measured, b[i].pressure_measured) << i;
        ASSERT_EQ(a[i].contraction, b[i].contraction) << i;
        ASSERT_EQ(a[i].pressure, b[i].pressure) << i;
        ASSERT_EQ(a[i].inlet_open, b[i].inlet_open) << i;
        ASSERT_EQ(a[i].exhaust_open, b[i].exhaust_open) << i;
      }
      EXPECT_EQ(la.contraction_measured, lb.contraction_measured);
      EXPECT_EQ(la.pressure_measured, lb.pressure_measured);
      // the noise stream continues alike after run()
      EXPECT_EQ(ra.step({0.3, 0.0, mode}).contraction_measured, rb.step({0.3, 0.0, mode}).contraction_measured);
    }
  }
}
TEST(PamRigParams, JsonRoundTripAndErrors) {
  PamRigParams p;
  p.load.mass = 12.5;
  p.sensors.pressure_bits = 10;
  const auto j = rig_params_to_json(p);
  const auto q = rig_params_from_json(j, "test");
  EXPECT_EQ(q.load.mass, 12.5);
  EXPECT_EQ(q.sensors.pressure_bits, 10);
  EXPECT_EQ(rig_params_to_json(q), j);
  // Partial files keep the defaults.
  EXPECT_EQ(rig_params_from_json(nlohmann::json::parse(R"({"load": {"mass": 3}})"), "x").load.damping,
            PamRigParams{}.load.damping);

  auto msg = [](const char* text) {
    return error_of([&] { rig_params_from_json(nlohmann::json::parse(text), "rig.json"); });
  };
  EXPECT_NE(msg(R"({"load": {"mas": 3}})").find("unknown key 'mas'"), std::string::npos);
  // the section's keys, and the closest when it looks like a typo (2026-11-29)
  EXPECT_NE(msg(R"({"load": {"mas": 3}})").find("did you mean 'mass'? (the keys of load: mass, damping, gravity"),
            std::string::npos) << msg(R"({"load": {"mas": 3}})");
  EXPECT_EQ(msg(R"({"load": {"volume": 3}})").find("did you mean"), std::string::npos);
  // a dead time's delay line is dead_time / dt samples: more than 10 s is refused (1e6 s ran out of memory)
  EXPECT_NE(msg(R"({"regulator": {"dead_time": 1e6}})").find("regulator.dead_time"), std::string::npos);
  EXPECT_NE(msg(R"({"regulator": {"dead_time": 10.5}})").find("<= 10 s"), std::string::npos);
  // a braid at or above the neutral angle atan(sqrt(2)) would lengthen under pressure
  EXPECT_NE(msg(R"({"muscle": {"rest_braid_angle": 1.0}})").find("rig.json.muscle.rest_braid_angle = 1.0: must be"),
            std::string::npos);
  EXPECT_NE(msg(R"({"muscle": {"rest_braid_angle": 0.96}})").find("54.74 deg"), std::string::npos);
  EXPECT_NO_THROW(rig_params_from_json(nlohmann::json::parse(R"({"muscle": {"rest_braid_angle": 0.95}})"), "x"));
  EXPECT_NE(msg(R"({"lode": {}})").find("unknown key 'lode'"), std::string::npos);
  const auto neg = msg(R"({"load": {"mass": -1}})");
  EXPECT_NE(neg.find("rig.json.load.mass"), std::string::npos) << neg;
  EXPECT_NE(neg.find("> 0"), std::string::npos) << neg;
  const auto type = msg(R"({"load": {"mass": "heavy"}})");
  EXPECT_NE(type.find("load.mass"), std::string::npos) << type;
  EXPECT_NE(type.find("string"), std::string::npos) << type;
  EXPECT_NE(msg(R"({"sensors": {"pressure_bits": 12.5}})").find("sensors.pressure_bits"), std::string::npos);
  EXPECT_NE(msg(R"({"simulation": {"dt": 1e-3}})").find("simulation.dt"), std::string::npos);
  EXPECT_NE(msg(R"({"air": {"supply_pressure": 5e4}})").find("air.supply_pressure"), std::string::npos);
  // physically impossible air: vacuum around the rig, a supply of 10 kbar
  EXPECT_NE(msg(R"({"air": {"atmospheric_pressure": 1}})").find("rig.json.air.atmospheric_pressure = 1: must be within"),
            std::string::npos);
  EXPECT_NE(msg(R"({"air": {"supply_pressure": 1e9}})").find("rig.json.air.supply_pressure = 1000000000: must be <="),
            std::string::npos);
  EXPECT_NO_THROW(rig_params_from_json(
      nlohmann::json::parse(R"({"air": {"supply_pressure": 1.7e6, "atmospheric_pressure": 7e4}})"), "x"));
  // values the experiments aborted on or that contradict docs/plant.md (2026-12-01): a minimum
  // pulse of the PWM period or more (every pulse dropped), a regulator range of 1e12 Pa, air at
  // 1 K, a divergence check disabled by its tolerance; each names its key and range
  EXPECT_NE(msg(R"({"valves": {"min_pulse": 0.006}})").find("rig.json.valves.min_pulse = 0.006: must be < the PWM "
                                                           "period 0.005 s"),
            std::string::npos) << msg(R"({"valves": {"min_pulse": 0.006}})");
  EXPECT_NE(msg(R"({"regulator": {"max_command": 1e12}})").find("rig.json.regulator.max_command = 1000000000000: "
                                                               "must be <= 5e6 Pa"),
            std::string::npos) << msg(R"({"regulator": {"max_command": 1e12}})");
  EXPECT_NE(msg(R"({"air": {"temperature": 1}})").find("rig.json.air.temperature = 1: must be within 150 .. 600 K"),
            std::string::npos);
  EXPECT_NE(msg(R"({"simulation": {"pressure_tolerance": 1e9}})").find("simulation.pressure_tolerance = 1000000000: "
                                                                      "must be <= 1"),
            std::string::npos);
  EXPECT_NE(msg(R"({"simulation": {"position_tolerance": 1e9}})").find("simulation.position_tolerance"),
            std::string::npos);
  EXPECT_NO_THROW(rig_params_from_json(nlohmann::json::parse(R"({"valves": {"min_pulse": 0.004}, "regulator": )"
                                                             R"({"max_command": 1.2e6}, "air": {"temperature": 330}})"),
                                       "x"));
  EXPECT_NE(msg(R"([1, 2])").find("expected a JSON object"), std::string::npos);
  // A muscle whose stroke (0.25 x 0.7 m) exceeds the displacement sensor's range (0.15 m): the
  // message names the key to change and why; a longer sensor makes the same rig valid.
  const auto stroke = msg(R"({"muscle": {"rest_length": 0.7}})");
  EXPECT_NE(stroke.find("rig.json.sensors.displacement_range = 0.15"), std::string::npos) << stroke;
  EXPECT_NE(stroke.find(">= the stroke 0.175 m"), std::string::npos) << stroke;
  EXPECT_NE(stroke.find("longer displacement sensor"), std::string::npos) << stroke;
  EXPECT_EQ(rig_params_from_json(
                nlohmann::json::parse(R"({"muscle": {"rest_length": 0.7}, "sensors": {"displacement_range": 0.2}})"),
                "x")
                .muscle.rest_length,
            0.7);
  nlohmann::json nan_json;
  nan_json["load"]["mass"] = NAN;
  EXPECT_NE(error_of([&] { rig_params_from_json(nan_json, "n"); }).find("n.load.mass"), std::string::npos);

  // Files.
  const auto path = std::filesystem::temp_directory_path() / "hysteron_test_rig.json";
  save_rig_params(p, path);
  EXPECT_EQ(load_rig_params(path).load.mass, 12.5);
  {
    std::ofstream(path) << "{ \"load\": { \"mass\": 1, } }";
  }
  EXPECT_NE(error_of([&] { load_rig_params(path); }).find(path.string()), std::string::npos);
  std::filesystem::remove(path);
  EXPECT_THROW(load_rig_params(path), Error);
}

// with_unread_parameters_of: what a sweep relies on to run a variant once. Rigs that differ
// only in parameters the actuation does not read give the same outputs bit for bit; rigs that
// differ in parameters it reads do not (the run below can tell them apart).
namespace {
std::vector<RigOutputs> drive(const PamRigParams& p, Actuation mode) {
  PamRig rig(p, 7);
  std::vector<RigOutputs> out;
  for (int k = 0; k < 30000; ++k) {
    const double t = k * p.simulation.dt;
    // both inputs move: the one the mode does not use must not matter either
    const double command = 0.3 + 0.2 * std::sin(2.0 * std::numbers::pi * 0.7 * t);  // MPa
    const double duty = 0.8 * std::sin(2.0 * std::numbers::pi * 0.5 * t);
    out.push_back(rig.step({command, duty, mode}));
  }
  return out;
}
bool same_outputs(const std::vector<RigOutputs>& a, const std::vector<RigOutputs>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t k = 0; k < a.size(); ++k)
    if (a[k].contraction != b[k].contraction || a[k].contraction_measured != b[k].contraction_measured ||
        a[k].velocity != b[k].velocity || a[k].pressure != b[k].pressure ||
        a[k].pressure_measured != b[k].pressure_measured || a[k].inlet_open != b[k].inlet_open ||
        a[k].exhaust_open != b[k].exhaust_open || a[k].ok != b[k].ok)
      return false;
  return true;
}
}  // namespace

TEST(PamRigUnread, ValvesDoNotReadTheRegulatorsLagAndTheRegulatorNotTheValvesTiming) {
  const PamRigParams base{};
  PamRigParams lag = base;  // the regulator's P9 parameters
  lag.regulator.time_constant = 0.1;
  lag.regulator.dead_time = 0.012;
  lag.regulator.max_command = 0.5e6;
  PamRigParams timing = base;  // the valves' P10 timing
  timing.valves.pwm_frequency = 100.0;
  timing.valves.on_delay = 2e-3;
  timing.valves.off_delay = 0.5e-3;
  timing.valves.min_pulse = 0.3e-3;
  const auto valves = Actuation::switching_valves, regulator = Actuation::regulator;

  EXPECT_EQ(rig_params_to_json(with_unread_parameters_of(lag, valves, base)), rig_params_to_json(base));
  EXPECT_EQ(rig_params_to_json(with_unread_parameters_of(timing, regulator, base)), rig_params_to_json(base));
  EXPECT_NE(rig_params_to_json(with_unread_parameters_of(lag, regulator, base)), rig_params_to_json(base));
  EXPECT_NE(rig_params_to_json(with_unread_parameters_of(timing, valves, base)), rig_params_to_json(base));

  EXPECT_TRUE(same_outputs(drive(base, valves), drive(lag, valves)));
  EXPECT_TRUE(same_outputs(drive(base, regulator), drive(timing, regulator)));
  EXPECT_FALSE(same_outputs(drive(base, regulator), drive(lag, regulator)));
  EXPECT_FALSE(same_outputs(drive(base, valves), drive(timing, valves)));

  // the stages' conductances are read under either mode (the sub-steps, P12)
  PamRigParams conductance = base;
  conductance.valves.sonic_conductance *= 4.0;
  EXPECT_NE(rig_params_to_json(with_unread_parameters_of(conductance, regulator, base)), rig_params_to_json(base));
}
