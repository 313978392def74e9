// Rig simulation speed: 60 s of closed loop (PI at 1 kHz on the regulator path,
// tracking the GPI paper's Eq. 18 sinusoid) at the default 1e-4 s rig step.
#include <benchmark/benchmark.h>

#include "hysteron/control.hpp"
#include "hysteron/plant.hpp"
#include "hysteron/signals.hpp"

namespace {

void BM_RigClosedLoop60s(benchmark::State& state) {
  const double ts = 1e-3;
  for (auto _ : state) {
    hysteron::PamRig rig(hysteron::PamRigParams{}, 1);
    hysteron::Pid pid(hysteron::PidParams{.kp = 1.0, .ki = 40.0, .sample_time = ts, .out_min = 0.0, .out_max = 0.6});
    const auto last = rig.run(60.0, ts, [&](const hysteron::RigOutputs& y) {
      return hysteron::RigInputs{pid.step(hysteron::gpi_sinusoid_contraction(y.time + ts), y.contraction_measured),
                                 0.0, hysteron::Actuation::regulator};
    });
    benchmark::DoNotOptimize(last.contraction);
  }
  state.SetItemsProcessed(state.iterations() * 600000);  // rig steps
}
BENCHMARK(BM_RigClosedLoop60s)->Unit(benchmark::kMillisecond)->Repetitions(5)->ReportAggregatesOnly(true);

void BM_RigSwitchingValves60s(benchmark::State& state) {
  for (auto _ : state) {
    hysteron::PamRig rig(hysteron::PamRigParams{}, 1);
    const auto last = rig.run(60.0, 1e-3, [](const hysteron::RigOutputs& y) {
      return hysteron::RigInputs{0.0, y.pressure < 0.3e6 ? 0.4 : -0.4, hysteron::Actuation::switching_valves};
    });
    benchmark::DoNotOptimize(last.contraction);
  }
  state.SetItemsProcessed(state.iterations() * 600000);
}
BENCHMARK(BM_RigSwitchingValves60s)->Unit(benchmark::kMillisecond)->Repetitions(3)->ReportAggregatesOnly(true);

}  // namespace
