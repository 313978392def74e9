function test_loop_runs(dir)
%TEST_LOOP_RUNS hysteron_loop replays the runs whose loop it rebuilds and refuses, with
% hysteron:error and a message saying why and what to use instead, the runs whose commands
% it would not reproduce: a learning run (its iterative learning) and an adaptive one (its
% online inverse). DIR: tests/c_api (the fixture result.json, mpi-pwm-like, and dz.json).
  fails = 0;
  rj = fullfile(dir, 'result.json');
  model = fullfile(dir, 'dz.json');
  r = 0.01 * ones(10, 1);
  o = hysteron_loop(rj, 'compensated.triangle', model, r, r, 0.3 * ones(10, 1));
  fails = fails + check_that(strcmp(o.loop, 'cascade_pwm') && numel(o.command_mpa) == 10, 'compensated.triangle: %s', o.loop);
  fails = fails + expect_error(@() hysteron_loop(rj, 'learning.triangle', model, r, r, r), 'hysteron:error', ...
                               {'learning.triangle', 'iterative learning', 'does not replay', 'hysteron_ilc', ...
                                'hysteron export --loop'});
  fails = fails + expect_error(@() hysteron_loop(rj, 'adaptive.sine', model, r, r, r), 'hysteron:error', ...
                               {'adapted online'});
  if fails > 0
    error('test_loop_runs: %d check(s) failed', fails);
  end
  fprintf('test_loop_runs: learning and adaptive runs refused\n');
end
