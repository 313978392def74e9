function p = hysteron_rig_params(params)
%HYSTERON_RIG_PARAMS The simulated rig's complete parameter struct.
%   P = HYSTERON_RIG_PARAMS() returns the nominal parameters of the simulated rig
%   (SI units; docs/plant.md): sections muscle, hysteresis, air, regulator, valves,
%   load, sensors, simulation.
%   P = HYSTERON_RIG_PARAMS(PARAMS) fills a partial struct (or a JSON file name)
%   with the defaults and checks it (unknown keys, non-finite or impossible values
%   are errors naming the key).
%
%   Example:
%     p = hysteron_rig_params(struct('load', struct('mass', 10)));
%
%   See also HYSTERON_RIG.
  if nargin < 1
    params = [];
  end
  p = hysteron_mex('rig_params', params);
end
