function out = hysteron_rig(pressure_mpa, varargin)
%HYSTERON_RIG Run the simulated pneumatic-muscle rig on a pressure command.
%   OUT = HYSTERON_RIG(P) drives the simulated rig (a Festo DMSP-20-500 muscle
%   lifting a hanging mass through a proportional pressure regulator;
%   docs/plant.md) with the pressure command P [MPa gauge], one value per control
%   period (1 ms), starting with the muscle vented and at rest. OUT is a struct of
%   column vectors logged at the end of each period:
%     t                         time [s]
%     pressure_command_mpa      the command P
%     pressure_mpa              measured chamber pressure [MPa gauge]
%     contraction_mm            true contraction [mm]
%     contraction_measured_mm   displacement sensor reading [mm]
%   OUT = HYSTERON_RIG(P, 'name', value, ...) with options
%     params           rig parameters: a (partial) struct with the sections muscle,
%                      hysteresis, air, regulator, valves, load, sensors, simulation
%                      (see hysteron_rig_params()), or a JSON file name
%     seed             seed of the sensor noise (default 1); a run is reproducible
%                      bit for bit for a seed
%     control_period   seconds per value of P (default 1e-3); a whole multiple of the
%                      rig's simulation.dt (an error names the nearest dt that divides it)
%   The same as the Python hysteron.PamRig(params, seed).run_pressure(P).
%
%   Example:
%     p = 0.3 * (1 - cos(2*pi*0.2*(0:1e-3:10)'));    % 0..0.6 MPa, 0.2 Hz
%     r = hysteron_rig(p, 'seed', 2);
%     plot(r.pressure_mpa, r.contraction_measured_mm);
%
%   Errors: hysteron:error (invalid parameters, a diverging simulation; the message
%   names the key or the time and the state), hysteron:nonFinite, hysteron:badArgument.
%   See also HYSTERON_RIG_PARAMS, HYSTERON_FIT.
  if nargin < 1
    error('hysteron:badArgument', 'usage: out = hysteron_rig(pressure_mpa, ''seed'', 1, ''params'', struct(...))');
  end
  out = hysteron_mex('rig', pressure_mpa, hysteron_options('hysteron_rig', varargin{:}));
end
