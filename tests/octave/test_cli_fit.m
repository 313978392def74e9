function test_cli_fit(cli, data_dir)
%TEST_CLI_FIT hysteron_fit on the shared Festo record (../shared/data/pam-force-pressure,
% pressure [kPa] -> force [N]) gives the same model as the command line `hysteron fit`
% (every parameter within 1e-9 relative) and the same status and training RMS, for
% several model kinds. Skipped (exit 77) with a message when the data or the CLI are absent.
  file = fullfile(data_dir, 'festo10mm_20cm_test8.csv');
  if ~exist(file, 'file')
    fprintf('SKIP: %s not found (the shared measured data live beside the project, in ../shared/data)\n', file);
    exit(77);
  end
  if isempty(cli) || ~exist(cli, 'file')
    fprintf('SKIP: the hysteron command line (%s) is not built\n', cli);
    exit(77);
  end
  fails = 0;
  dir = tempname();
  mkdir(dir);
  cleanup = onCleanup(@() rmdir(dir, 's'));
  d = dlmread(file, ',');
  x = d(:, 2);   % pressure [kPa]
  y = d(:, 1);   % force [N]
  kinds = {'gpi', 'pi', 'mpi-deadzone', 'mpi-asym'};
  for i = 1:numel(kinds)
    out = fullfile(dir, [kinds{i} '.json']);
    rep = fullfile(dir, [kinds{i} '_report.json']);
    tic;
    [status, text] = system(sprintf('"%s" fit --model %s --data "%s" --input 1 --output 0 --out "%s" --report "%s" --force 2>&1', ...
                                    cli, kinds{i}, file, out, rep));
    t_cli = toc;
    if ~any(status == [0 2 3])
      error('hysteron:test', 'hysteron fit --model %s: exit %d: %s', kinds{i}, status, text);
    end
    cli_model = hysteron_load_model(out);
    cli_report = jsondecode(fileread(rep));
    tic;
    w = warning('off', 'hysteron:fitStatus');
    [model, report] = hysteron_fit(x, y, 'model', kinds{i});
    warning(w);
    t_mex = toc;
    fails = fails + check(strcmp(report.status, cli_report.status), '%s: status %s vs %s from the CLI', kinds{i}, ...
                          report.status, cli_report.status);
    fails = fails + check(close(report.train.rms, cli_report.train.rms), '%s: train rms %.17g vs %.17g', kinds{i}, ...
                          report.train.rms, cli_report.train.rms);
    model = rmfield_if(model, 'note');
    cli_model = rmfield_if(cli_model, 'note');
    [worst, where] = compare_struct(model, cli_model, 'model');
    fails = fails + check(worst <= 1e-9, '%s: parameter %s differs by %.3g relative (> 1e-9)', kinds{i}, where, worst);
    if worst == 0
      where = 'every parameter bit for bit';
    end
    fprintf('%-13s status %-10s train rms %.6g N; largest parameter difference %.3g relative (%s); %.2f s (CLI %.2f s)\n', ...
            kinds{i}, report.status, report.train.rms, worst, where, t_mex, t_cli);
  end
  if fails > 0
    error('test_cli_fit: %d check(s) failed', fails);
  end
  fprintf('test_cli_fit: hysteron_fit matches hysteron fit on %s\n', file);
end

function ok = close(a, b)
  ok = abs(a - b) <= 1e-9 * max(abs(a), abs(b));
end

function s = rmfield_if(s, name)
  if isfield(s, name)
    s = rmfield(s, name);
  end
end

% Largest relative difference over every number of two structs with the same fields.
function [worst, where] = compare_struct(a, b, path)
  worst = 0;
  where = '';
  fa = sort(fieldnames(a));
  fb = sort(fieldnames(b));
  if ~isequal(fa, fb)
    worst = Inf;
    where = sprintf('%s (fields %s vs %s)', path, strjoin(fa', ','), strjoin(fb', ','));
    return;
  end
  for k = 1:numel(fa)
    va = a.(fa{k});
    vb = b.(fa{k});
    p = [path '.' fa{k}];
    if isstruct(va)
      [w, wh] = compare_struct(va, vb, p);
    elseif ischar(va)
      w = Inf * ~strcmp(va, vb);
      wh = p;
    elseif ~isequal(size(va), size(vb))
      w = Inf;
      wh = sprintf('%s (size)', p);
    else
      d = abs(va - vb) ./ max(max(abs(va), abs(vb)), realmin);
      d(va == vb) = 0;
      w = max([0; d(:)]);
      wh = p;
    end
    if w > worst || isempty(where)
      worst = w;
      where = wh;
    end
  end
end

function failed = check(ok, varargin)
  failed = ~ok;
  if failed
    fprintf('FAIL: %s\n', sprintf(varargin{:}));
  end
end
