function y = hysteron_simulate(model, x, varargin)
%HYSTERON_SIMULATE Run a hysteresis model forwards: input samples -> output.
%   Y = HYSTERON_SIMULATE(MODEL, X) runs MODEL on the input vector X from its virgin
%   state (all operators at 0) and returns the output Y, shaped like X.
%   Y = HYSTERON_SIMULATE(MODEL, X, 'relaxed', true) starts at rest at X(1) instead
%   (as hysteron_fit's initial_state 'relaxed').
%
%   MODEL is a model struct (hysteron_fit, hysteron_load_model, hysteron_model), the
%   JSON text of a model file or the name of a model file (docs/model-files.md).
%   X must be a real, finite double vector.
%
%   Example:
%     gpi = struct('model', 'gpi', 'c', [60 4 -0.5 30], 'q', 0.8, 'n', 10, ...
%                  'rho', 0.4, 'tau', 0.1, 'alpha', 2);
%     y = hysteron_simulate(gpi, 0.6 * sin(linspace(0, 4*pi, 800)).^2);
%
%   Errors have identifiers hysteron:badModel, hysteron:modelFile,
%   hysteron:nonFinite, hysteron:badArgument.
%   See also HYSTERON_INVERT, HYSTERON_FIT, HYSTERON_LOAD_MODEL.
  if nargin < 2
    error('hysteron:badArgument', 'usage: y = hysteron_simulate(model, x, [''relaxed'', true])');
  end
  y = hysteron_mex('simulate', model, x, hysteron_options('hysteron_simulate', varargin{:}));
end
