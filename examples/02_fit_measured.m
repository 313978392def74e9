% Fit a GPI model to measured data: Festo 10 mm muscle, force [N] (column 1)
% against pressure [kPa] (column 2), if the shared data set is present; else to
% data simulated here (and say so). The same as 02_fit_measured.cpp and .py.
% Set csv_file before running it to use another record:
%   octave-cli --eval "addpath('matlab', 'build/matlab'); csv_file = 'rig.csv'; source('examples/02_fit_measured.m')"
if exist('hysteron_mex') ~= 3 %#ok<EXIST>
  error('hysteron:example', 'hysteron_mex not found: addpath the matlab/ directory and the build''s matlab/ directory');
end
if ~exist('csv_file', 'var')
  csv_file = '../shared/data/pam-force-pressure/festo10mm_20cm_test8.csv';
end
if exist(csv_file, 'file')
  data = dlmread(csv_file, ',');
  x = data(1:5:end, 2);                  % pressure [kPa]; 15000 -> 3000 samples
  y = data(1:5:end, 1);                  % force [N]
  fprintf('measured data: %s (%d samples used)\n', csv_file, numel(x));
else
  gpi = struct('model', 'gpi', 'c', [300 0.004 -0.5 150], 'q', 0.8, 'n', 10, 'rho', 0.4, ...
               'tau', 0.01, 'alpha', 20);
  k = (0:399) / 400;
  x = [];
  for a = [600 500 400 300 200 100]
    x = [x, a * (1 - abs(2 * k - 1))]; %#ok<AGROW>
  end
  y = hysteron_simulate(gpi, x) + 0.5 * sin(0.7 * (0:numel(x) - 1));
  fprintf('%s not found: fitting data simulated in this example instead\n', csv_file);
end

[model, report] = hysteron_fit(x, y, 'model', 'gpi', 'num_operators', 10);
disp(report.report);
good = ~any(strcmp(report.status, {'invalid_input', 'failed'})) && report.train.r2 > 0.95;
verdict = 'ok';
if ~good
  verdict = 'FAILED';
end
fprintf('R^2 = %.5f, RMS = %.3g N (%.2f %% of span): %s\n', report.train.r2, report.train.rms, ...
        report.train.rms_percent_span, verdict);
if ~good
  error('hysteron:example', 'the fit is not good enough (status %s, R^2 %.5f)', report.status, report.train.r2);
end
