function test_cli_invert(cli, c_api_dir)
%TEST_CLI_INVERT hysteron_invert on a model file gives the same inverse trajectory as
% the command line `hysteron invert --model FILE` (bit for bit, or within 1e-12
% relative), for every model kind, with and without --limits; hysteron_simulate the
% same as `hysteron simulate`. CLI: the hysteron executable (skipped if absent).
% C_API_DIR (optional): the model files the C ABI's tests use (tests/c_api/{gpi,pi,dz,
% asym,asym_mirrored}.json): the same comparison on them, with the input of tests/c_api/cli_equal.sh,
% so that the C program, the ctypes script and Octave are checked on the same files.
  if nargin < 1 || isempty(cli) || ~exist(cli, 'file')
    fprintf('SKIP: the hysteron command line (%s) is not built\n', cli);
    exit(77);
  end
  fails = 0;
  dir = tempname();
  mkdir(dir);
  cleanup = onCleanup(@() rmdir(dir, 's'));
  k = (0:299) / 300;
  x = [];
  for a = [0.6 0.45 0.55 0.2 0.35 0.1]
    x = [x, 0.02 + a * (1 - abs(2 * k - 1))]; %#ok<AGROW>
  end
  x = x(:);
  models = struct();
  models.gpi = struct('model', 'gpi', 'c', [60 4 -0.5 30], 'q', 0.8, 'n', 10, 'rho', 0.4, 'tau', 0.1, ...
                      'alpha', 2, 'input_limits', [0 0.6]);
  models.pi_decreasing = struct('model', 'pi', 'q', 0.09, 'r', [0.05 0.1 0.2], 'p', [0.72 -0.04 0.1], ...
                                'input_origin', 0.05, 'input_scale', 2, 'output_offset', -40, 'output_gain', -1);
  models.mpi_asym_mirrored = struct('model', 'mpi-asym', 'q', 1, 'r', [0.05 0.1 0.2], 'p', [0.3 0.2 0.1], ...
                                    'ascending', struct('envelope', 'tanh', 'c', [1 2 0 0]), ...
                                    'descending', struct('envelope', 'affine', 'c', [0.8 0]), ...
                                    'input_origin', 0.6, 'input_scale', -1, 'output_gain', -1, 'input_limits', [0 0.6]);
  models.mpi_deadzone = struct('model', 'mpi-deadzone', 'q', 0.8, 'r', [0.1 0.2], 'p', [0.3 0.1], ...
                               'g0', 1, 'z', [-0.5 0.25], 'g', [0.2 0.3]);
  models.mpi_asym = struct('model', 'mpi-asym', 'q', 1, 'r', [0.05 0.1 0.2], 'p', [0.3 0.2 0.1], ...
                           'ascending', struct('envelope', 'tanh', 'c', [1 2 0 0]), ...
                           'descending', struct('envelope', 'affine', 'c', [0.8 0]), 'input_limits', [0 0.6]);
  names = fieldnames(models);
  files = cellfun(@(n) fullfile(dir, [n '.json']), names, 'UniformOutput', false);
  for i = 1:numel(names)
    hysteron_save_model(files{i}, models.(names{i}));
  end
  limits = {[], [0.01 0.5]};
  fails = fails + compare_all(cli, dir, names, files, x, limits);
  % the C ABI tests' model files, on their input signal
  if nargin >= 2 && ~isempty(c_api_dir)
    shared = {'gpi', 'pi', 'dz', 'asym', 'asym_mirrored'};
    shared_files = cellfun(@(n) fullfile(c_api_dir, [n '.json']), shared, 'UniformOutput', false);
    present = cellfun(@(f) exist(f, 'file') == 2, shared_files);
    if any(present)
      k = (0:4999)';
      xs = 0.8 * sin(0.013 * k) .* exp(-k / 3000) + 0.15 * sin(0.17 * k) + 0.02 * sin(1.3 * k);
      fails = fails + compare_all(cli, dir, strcat('c_api/', shared(present)), shared_files(present), xs, {[]});
    else
      fprintf('note: no model files in %s (the C ABI tests'' files): not compared\n', c_api_dir);
    end
  end
  if fails > 0
    error('test_cli_invert: %d comparison(s) failed', fails);
  end
  fprintf('test_cli_invert: hysteron_invert and hysteron_simulate match the CLI\n');
end

% simulate x and invert the outputs (plus some beyond reach) with the CLI and the MEX on
% the same model files; the number of comparisons that failed.
function fails = compare_all(cli, dir, names, files, x, limits)
  fails = 0;
  for i = 1:numel(names)
    file = files{i};
    % forward: the CLI and the MEX on the same file
    write_column(fullfile(dir, 'x.csv'), 'input', x);
    run_cli(cli, sprintf('simulate --model "%s" --input "%s" --column input --output "%s"', file, ...
                         fullfile(dir, 'x.csv'), fullfile(dir, 'y.csv')));
    y_cli = read_column(fullfile(dir, 'y.csv'), 2);
    y = hysteron_simulate(file, x);
    fails = fails + compare(sprintf('%s simulate', names{i}), y, y_cli);
    % desired outputs: the simulated ones plus some out of reach (saturation)
    y_desired = [y; max(y) + 5 * (max(y) - min(y)); y(1:100)];
    write_column(fullfile(dir, 'y_desired.csv'), 'output', y_desired);
    for l = 1:numel(limits)
      args = '';
      opts = {};
      if ~isempty(limits{l})
        args = sprintf(' --limits=%.17g,%.17g', limits{l});
        opts = {'limits', limits{l}};
      end
      run_cli(cli, sprintf('invert --model "%s" --input "%s" --column output --output "%s"%s', file, ...
                           fullfile(dir, 'y_desired.csv'), fullfile(dir, 'x_cli.csv'), args));
      x_cli = read_column(fullfile(dir, 'x_cli.csv'), 2);
      x_mex = hysteron_invert(file, y_desired, opts{:});
      fails = fails + compare(sprintf('%s invert%s', names{i}, args), x_mex, x_cli);
    end
  end
end

function failed = compare(what, a, b)
  failed = true;
  if ~isequal(size(a), size(b))
    fprintf('FAIL: %s: %d samples vs %d from the CLI\n', what, numel(a), numel(b));
    return;
  end
  d = abs(a - b);
  rel = max(d ./ max(1, abs(b)));
  same = sum(a == b);
  fprintf('%-40s %5d samples, %5d bit for bit, max |difference| %.3g (relative %.3g)\n', what, numel(a), same, max(d), rel);
  failed = ~(rel <= 1e-12);
  if failed
    fprintf('FAIL: %s differs from the CLI by %.3g relative (> 1e-12)\n', what, rel);
  end
end

function write_column(file, name, v)
  fid = fopen(file, 'w');
  fprintf(fid, '%s\n', name);
  fprintf(fid, '%.17g\n', v);
  fclose(fid);
end

function v = read_column(file, col)
  d = dlmread(file, ',', 1, 0);
  v = d(:, col);
end

function run_cli(cli, args)
  [status, out] = system(sprintf('"%s" %s 2>&1', cli, args));
  if status ~= 0
    error('hysteron:test', 'hysteron %s: exit %d: %s', args, status, out);
  end
end
