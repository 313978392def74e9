function test_fit_faults()
%TEST_FIT_FAULTS hysteron_fit's report.fault_runs (1-based rows) and fault_free_train: where the warnings name sensor-fault rows (here the
% output's reading frozen over samples 361..440 while the input rises), the longest stretch of the training range
% free of them, 1-based and inclusive as the 'train' option, which trains there without them; [] on a clean record.
  fails = 0;
  gpi = struct('model', 'gpi', 'c', [60 4 -0.5 30], 'q', 0.8, 'n', 10, 'rho', 0.4, 'tau', 0.1, 'alpha', 2);
  x = [];
  for a = [0.6 0.5 0.4 0.3 0.2 0.1]
    x = [x, interp1([0 0.5 1], [0 a 0], linspace(0, 1, 300))];
  end
  y = hysteron_simulate(gpi, x);
  stuck = y;
  stuck(361:440) = stuck(361);
  old = warning('off', 'hysteron:fitStatus');
  [~, r] = hysteron_fit(x, stuck, 'model', 'gpi', 'min_slope', 0.01);
  fails = fails + check_that(isequal(r.fault_free_train, [441 1800]), 'stuck: fault_free_train %s', ...
                             mat2str(r.fault_free_train));
  fails = fails + check_that(numel(r.fault_runs) == 1 && isequal(r.fault_runs(1).rows, [361 440]) && ...
                             strcmp(r.fault_runs(1).column, 'output'), 'stuck: fault_runs');
  fails = fails + check_that(any(~cellfun(@isempty, strfind(r.warnings, 'train on samples 440:1800'))), ...
                             'stuck: no advice 440:1800 in the warnings');
  [~, again] = hysteron_fit(x, stuck, 'model', 'gpi', 'min_slope', 0.01, 'train', r.fault_free_train);
  fails = fails + check_that(strcmp(again.status, 'converged') && again.train.n == 1360 && ...
                             isempty(again.fault_free_train), 'refit on it: %s, n %d', again.status, again.train.n);
  [~, clean] = hysteron_fit(x, y, 'model', 'gpi', 'min_slope', 0.01);
  fails = fails + check_that(isempty(clean.fault_free_train) && isempty(clean.fault_runs), ...
                             'clean: fault_free_train %s', mat2str(clean.fault_free_train));
  warning(old);
  if fails > 0
    error('test_fit_faults: %d check(s) failed', fails);
  end
  fprintf('test_fit_faults: fault_free_train names the stretch to train on\n');
end
