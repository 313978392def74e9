// hysteron::rig: the simulated muscle at a constant pressure contracts.
#include <hysteron/plant.hpp>

#include <cstdio>

int main() {
  hysteron::PamRig rig(hysteron::PamRigParams{}, 1);
  rig.reset();
  hysteron::RigOutputs out{};
  hysteron::RigInputs in{};
  in.pressure_command = 0.3;  // MPa gauge
  for (int k = 0; k < 20000; ++k) out = rig.step(in);
  std::printf("consumer rig: contraction %.4g m at 0.3 MPa\n", out.contraction);
  return out.contraction > 0.001 ? 0 : 1;
}
