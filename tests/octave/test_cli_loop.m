function test_cli_loop(cli)
%TEST_CLI_LOOP hysteron_loop rebuilds the loops of `hysteron experiment mpi-pwm` and
% `gpi-pid` from result.json and the model files and, fed each run's tracking CSV,
% commands what the run commanded (within 1e-9 MPa and 1e-9 in the duty); and its errors.
% CLI: the hysteron executable (skipped if absent).
  if nargin < 1 || isempty(cli) || ~exist(cli, 'file')
    fprintf('SKIP: the hysteron command line (%s) is not built\n', cli);
    exit(77);
  end
  fails = 0;
  dir = tempname();
  mkdir(dir);
  cleanup = onCleanup(@() rmdir(dir, 's'));
  runs = {'mpi-pwm', {'compensated.triangle', 'faithful.sine'}; 'gpi-pid', {'compensated', 'faithful'}};
  for e = 1:size(runs, 1)
    out = fullfile(dir, runs{e, 1});
    [st, text] = system(sprintf('"%s" experiment %s --out "%s" --learning-periods 0 --no-adaptive --model mpi-asym', ...
                                cli, runs{e, 1}, out));
    if st ~= 0
      fprintf('FAIL: hysteron experiment %s: %s\n', runs{e, 1}, text);
      exit(1);
    end
    for r = 1:numel(runs{e, 2})
      run = runs{e, 2}{r};
      parts = strsplit(run, '.');
      variant = parts{1};
      if numel(parts) > 1
        ref = parts{2};
      else
        ref = 'sine';
      end
      csv = fullfile(out, sprintf('tracking_%s_%s.csv', variant, ref));
      fid = fopen(csv);
      header = strsplit(fgetl(fid), ',');
      fclose(fid);
      c = dlmread(csv, ',', 1, 0);
      col = @(name) c(:, find(strcmp(header, name), 1));
      if strcmp(variant, 'faithful')
        model = fullfile(out, 'model.json');
      else
        model = fullfile(out, 'best_model.json');
      end
      o = hysteron_loop(fullfile(out, 'result.json'), run, model, col('reference_mm') * 1e-3, ...
                        col('measured_mm') * 1e-3, col('pressure_measured_mpa'));
      dc = max(abs(o.command_mpa - col('pressure_command_mpa')));
      dd = max(abs(o.duty - col('pwm_duty')));
      fails = fails + check_that(dc < 1e-9 && dd < 1e-9, '%s %s: command differs by %g MPa, duty by %g', runs{e, 1}, run, dc, dd);
      fails = fails + check_that(numel(o.command_mpa) == size(c, 1) && numel(o.preview_m) == size(c, 1), '%s: sizes', run);
      printf('ok   %s %s (%s): %d samples, largest difference %.3g MPa, %.3g in the duty\n', runs{e, 1}, run, ...
             o.loop, size(c, 1), dc, dd);
    end
  end
  % errors: the message names what is there
  rj = fullfile(dir, 'mpi-pwm', 'result.json');
  bm = fullfile(dir, 'mpi-pwm', 'best_model.json');
  fails = fails + expect_error(@() hysteron_loop(rj, 'compensated', bm, [0; 0], [0; 0], [0; 0]), ...
                               'hysteron:badArgument', 'one run per reference');
  fails = fails + expect_error(@() hysteron_loop(rj, 'nope', bm, [0; 0], [0; 0], [0; 0]), ...
                               'hysteron:badArgument', 'no run "nope"');
  fails = fails + expect_error(@() hysteron_loop(rj, 'compensated.sine', bm, [0; 0], [0; 0]), ...
                               'hysteron:badArgument', 'give the measured pressure');
  fails = fails + expect_error(@() hysteron_loop(rj, 'compensated.sine', bm, [0; 0], [0; 0; 0], [0; 0]), ...
                               'hysteron:badArgument', 'measured_m has 3 values');
  fails = fails + expect_error(@() hysteron_loop(rj, 'compensated.sine', bm, [0; NaN], [0; 0], [0; 0]), ...
                               'hysteron:nonFinite', 'reference_m');
  fails = fails + expect_error(@() hysteron_loop(fullfile(dir, 'none.json'), 'compensated.sine', bm, 0, 0, 0), ...
                               'hysteron:badArgument', 'cannot open result file');
  % a model whose input is in kPa: refused as by the C ABI and controller_from (the loop is in MPa)
  txt = fileread(bm);
  kpa = strrep(txt, '"input": "MPa"', '"input": "kPa"');
  fails = fails + expect_error(@() hysteron_loop(rj, 'compensated.sine', kpa, [0; 0], [0; 0], [0; 0]), ...
                               'hysteron:badModel', 'the model''s input is in kPa, not MPa');
  if fails > 0
    fprintf('%d failure(s)\n', fails);
    exit(1);
  end
  printf('all checks passed\n');
end
