% Simulate a GPI model (GPI paper, Eqs. 5-8) on a decaying triangle input and
% invert its output exactly: the input must come back to 1e-9.
% The same as 01_simulate_invert.cpp and 01_simulate_invert.py.
% Needs matlab/ and the built hysteron_mex on the path (docs/matlab.md):
%   octave-cli --eval "addpath('matlab', 'build/matlab'); source('examples/01_simulate_invert.m')"
if exist('hysteron_mex') ~= 3 %#ok<EXIST>
  error('hysteron:example', 'hysteron_mex not found: addpath the matlab/ directory and the build''s matlab/ directory');
end
gpi = struct('model', 'gpi', 'envelope', 'tanh', 'c', [60 4 -0.5 30], 'q', 0.8, 'n', 10, ...
             'rho', 0.4, 'tau', 0.1, 'alpha', 2, 'input_limits', [0 0.6]);

k = (0:399) / 400;
x = [];                                  % pressure [MPa]: triangles 0.6, 0.5, ..., 0.1 MPa
for a = [0.6 0.5 0.4 0.3 0.2 0.1]
  x = [x, a * (1 - abs(2 * k - 1))]; %#ok<AGROW>
end
y = hysteron_simulate(gpi, x);           % contraction [mm]
back = hysteron_invert(gpi, y);          % pressure [MPa]
err = max(abs(back - x));
fprintf('GPI: %d samples, output %.2f..%.2f mm; inverse round trip max error %.3g MPa\n', ...
        numel(x), min(y), max(y), err);
if ~(err < 1e-9)
  error('hysteron:example', 'the inverse round trip error %g is above 1e-9', err);
end
