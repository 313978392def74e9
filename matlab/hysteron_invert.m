function [x, saturated] = hysteron_invert(model, y, varargin)
%HYSTERON_INVERT Exact inverse of a hysteresis model: desired output -> input.
%   X = HYSTERON_INVERT(MODEL, Y) returns the input X that makes MODEL (started in
%   its virgin state) output Y, sample by sample; X is shaped like Y. pi, gpi and
%   mpi-deadzone are inverted analytically (GPI paper, Eqs. 9-11), mpi-asym exactly
%   per sample by bracketing (it needs finite input limits).
%   X = HYSTERON_INVERT(MODEL, Y, 'limits', [LO HI]) saturates at the input limits
%   LO, HI (default: the model's input_limits); an output beyond reach gives the
%   nearest limit.
%   [X, SATURATED] = HYSTERON_INVERT(...) also returns a logical vector, true where
%   the sample saturated at a limit.
%
%   MODEL is a model struct, the JSON text of a model file or a model file name.
%   The same as the command line `hysteron invert --model M --input Y --limits=LO,HI`.
%
%   Example:
%     x = linspace(0, 0.6, 300);
%     y = hysteron_simulate(gpi, x);
%     back = hysteron_invert(gpi, y);     % == x to rounding
%
%   See also HYSTERON_SIMULATE, HYSTERON_FIT.
  if nargin < 2
    error('hysteron:badArgument', 'usage: [x, saturated] = hysteron_invert(model, y, [''limits'', [lo hi]])');
  end
  [x, saturated] = hysteron_mex('invert', model, y, hysteron_options('hysteron_invert', varargin{:}));
end
