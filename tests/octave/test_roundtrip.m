function test_roundtrip()
%TEST_ROUNDTRIP invert(simulate(x)) == x for every model kind, from structs, JSON text
% and model files; model struct <-> JSON <-> file round trips are exact; vectors keep
% their orientation. Run by ctest (octave.roundtrip); an error exits Octave with 1.
  fails = 0;
  dir = tempname();
  mkdir(dir);
  cleanup = onCleanup(@() rmdir(dir, 's'));

  k = (0:399) / 400;
  x = [];
  for a = [0.6 0.5 0.4 0.3 0.2 0.1]
    x = [x, a * (1 - abs(2 * k - 1))]; %#ok<AGROW>
  end
  models = kinds();
  names = fieldnames(models);
  for i = 1:numel(names)
    m = models.(names{i});
    y = hysteron_simulate(m, x);
    back = hysteron_invert(m, y);
    err = max(abs(back - x));
    fails = fails + check(err <= 1e-9, '%s: invert(simulate(x)) max error %g > 1e-9', names{i}, err);
    fails = fails + check(isequal(size(y), size(x)) && isequal(size(back), size(x)), '%s: row vectors must stay rows', names{i});
    yc = hysteron_simulate(m, x(:));
    fails = fails + check(iscolumn(yc) && isequal(yc, y(:)), '%s: a column input gives the same column output', names{i});
    fails = fails + check(max(abs(y - mean(y))) > 0, '%s: the output is constant', names{i});
    % the complete struct, the JSON text and a model file give the same model, bit for bit
    s = hysteron_model(m);
    text = hysteron_model_json(m);
    file = fullfile(dir, [names{i} '.json']);
    hysteron_save_model(file, m);
    loaded = hysteron_load_model(file);
    fails = fails + check(isequal(loaded, s), '%s: load(save(m)) differs from hysteron_model(m)', names{i});
    fails = fails + check(isequal(hysteron_model(text), s), '%s: hysteron_model(json text) differs', names{i});
    fails = fails + check(isequal(hysteron_simulate(file, x), y), '%s: simulate from the file differs', names{i});
    fails = fails + check(isequal(hysteron_simulate(text, x), y), '%s: simulate from the JSON text differs', names{i});
    fails = fails + check(isequal(hysteron_invert(loaded, y), back), '%s: invert of the loaded struct differs', names{i});
    fails = fails + check(isequal(hysteron_model(s), s), '%s: hysteron_model is not idempotent', names{i});
    % its own output scores rms 0
    e = hysteron_evaluate(m, x, y);
    fails = fails + check(e.rms == 0 && e.n == numel(x), '%s: evaluate on its own output: rms %g, n %d', names{i}, e.rms, e.n);
    e2 = hysteron_evaluate(m, x, y + 1, 'range', [11 20]);
    fails = fails + check(abs(e2.rms - 1) < 1e-12 && e2.n == 10, '%s: evaluate range [11 20]: rms %g n %d', names{i}, e2.rms, e2.n);
  end

  % a clipped output (a sensor's lower limit c) scored as censored data when asked: a sample at
  % c that the model puts below c counts as met, every other sample as recorded
  g = models.gpi;
  y = hysteron_simulate(g, x);
  c = min(y) + 0.25 * (max(y) - min(y));
  yc = max(y + 0.3, c);
  plain = hysteron_evaluate(g, x, yc);
  cens = hysteron_evaluate(g, x, yc, 'censored', true);
  met = (yc == c) & (y < c);
  err = yc - y;
  err(met) = 0;
  fails = fails + check(~isfield(plain, 'censored_samples'), 'evaluate without censored: no censored_samples field');
  fails = fails + check(isfield(cens, 'censored_samples') && cens.censored_samples == sum(met) && sum(met) > 0, ...
                        'censored_samples %d, expected %d', cens.censored_samples, sum(met));
  fails = fails + check(abs(cens.rms - sqrt(mean(err .^ 2))) < 1e-12 && cens.rms < plain.rms, ...
                        'censored rms %g, expected %g (as recorded %g)', cens.rms, sqrt(mean(err .^ 2)), plain.rms);
  fails = fails + check(abs(plain.rms - sqrt(mean((yc - y) .^ 2))) < 1e-12, 'as recorded rms %g', plain.rms);
  off = hysteron_evaluate(g, x, yc, 'censored', false);
  fails = fails + check(isequal(off, plain), 'censored false differs from the default');
  % ... and fitted as censored data by default, as recorded with 'censor_passes', 0
  [~, as_recorded] = hysteron_fit(x, yc, 'model', 'pi', 'censor_passes', 0);
  [~, censored_fit] = hysteron_fit(x, yc, 'model', 'pi');
  said = @(r, text) any(cellfun(@(w) ~isempty(strfind(w, text)), r.warnings));
  fails = fails + check(said(censored_fit, 'fitted as censored data') && ~said(as_recorded, 'fitted as censored data') ...
                        && said(as_recorded, 'fitted to the limit'), 'censor_passes: the fits'' warnings do not say it');

  % saturation: outputs beyond reach give the limits, flagged
  g = models.gpi;
  y = hysteron_simulate(g, x);
  [xs, sat] = hysteron_invert(g, [y, max(y) + 100, min(y) - 100], 'limits', [0 0.6]);
  fails = fails + check(xs(end - 1) == 0.6 && xs(end) == 0 && sat(end) && sat(end - 1) && ~any(sat(1:10)), ...
                        'saturation at [0 0.6]: got %g, %g', xs(end - 1), xs(end));
  fails = fails + check(islogical(sat) && isequal(size(sat), size(xs)), 'saturated: a logical vector like x');

  % unbounded limits: -Inf/Inf in MATLAB, null in the file; extras are kept
  p = struct('model', 'pi', 'q', 0.4, 'r', 0.1, 'p', 0.3, 'input_limits', [-Inf 0.6], ...
             'note', 'one operator', 'units', struct('input', 'MPa', 'output', 'mm'));
  file = fullfile(dir, 'pi1.json');
  hysteron_save_model(file, p);
  q = hysteron_load_model(file);
  fails = fails + check(isequal(q.input_limits, [-Inf 0.6]), 'input_limits [-Inf 0.6] lost: %s', mat2str(q.input_limits));
  fails = fails + check(strcmp(q.note, 'one operator') && strcmp(q.units.output, 'mm'), 'note/units not kept');
  fails = fails + check(q.r == 0.1 && q.p == 0.3, 'one-element arrays r, p');
  txt = fileread(file);
  fails = fails + check(~isempty(strfind(txt, 'null')), 'the file should hold null for -Inf: %s', txt);

  % relaxed start: the first output is the rest curve, not the virgin branch
  yv = hysteron_simulate(g, 0.3 + 0 * (1:5));
  yr = hysteron_simulate(g, 0.3 + 0 * (1:5), 'relaxed', true);
  fails = fails + check(yv(1) ~= yr(1), 'relaxed start gives the virgin output');
  % empty input
  fails = fails + check(isempty(hysteron_simulate(g, zeros(0, 1))), 'empty input');

  % a fit that writes its HTML report
  html = fullfile(dir, 'fit.html');
  [mfit, rfit] = hysteron_fit(x, hysteron_simulate(g, x), 'model', 'pi', 'report', html, ...
                              'input_axis', {'Pressure', 'MPa'}, 'output_axis', {'Contraction', 'mm'});
  text = fileread(html);
  fails = fails + check(strncmp(text, '<!DOCTYPE html>', 15) && ~isempty(strfind(text, 'Contraction')), ...
                        'the HTML report of hysteron_fit');
  fails = fails + check(strcmp(mfit.model, 'pi') && rfit.train.r2 > 0.9, 'pi fit of the gpi output: r2 %g', rfit.train.r2);

  % the other kinds the model reader has, as JSON text and as the struct hysteron_model returns
  % (one-element arrays come back as scalars, and rate-pi's c is a number, not an array)
  texts = {
    '{"model": "preisach", "q": 0.5, "lo": 0, "hi": 0.6, "levels": 1, "w": [2]}'
    '{"model": "kp", "q": 0.5, "lo": 0, "hi": 0.6, "levels": 2, "w": [1, 2, 3]}'
    '{"model": "bouc-wen", "kx": 1, "kw": 0.5, "rho": 10, "sigma": 0.5, "n": 1}'
    '{"model": "maxwell-slip", "k0": 1, "k": [2], "delta": [0.1]}'
    '{"model": "rate-pi", "q": 0.1, "r": [0, 0.1], "p": [0.3, 0.2], "c": 0.1, "tau": 0.05, "dt": 0.001}'
  };
  for i = 1:numel(texts)
    try
      s = hysteron_model(texts{i});
      y = hysteron_simulate(texts{i}, x);
      fails = fails + check(isequal(hysteron_simulate(s, x), y) && isequal(hysteron_model(s), s), ...
                            '%s: the struct gives another model', s.model);
    catch err
      fails = fails + check(false, '%s: %s', texts{i}, err.message);
    end
  end

  if fails > 0
    error('test_roundtrip: %d check(s) failed', fails);
  end
  fprintf('test_roundtrip: all checks passed (%d model kinds)\n', numel(names));
end

function m = kinds()
  m.gpi = struct('model', 'gpi', 'c', [60 4 -0.5 30], 'q', 0.8, 'n', 10, 'rho', 0.4, 'tau', 0.1, ...
                 'alpha', 2, 'input_limits', [0 0.6]);
  m.gpi_free = struct('model', 'gpi', 'envelope', 'atan', 'c', [0.9 1.1 -0.2 0], 'q', 0.4, ...
                      'r', [0.05 0.1 0.3], 'p', [0.2 0.03 0.05]);
  % a decreasing pi in raw units (the units map of a fit)
  m.pi = struct('model', 'pi', 'q', 0.09, 'r', [0.05 0.1 0.2], 'p', [0.72 -0.04 0.1], ...
                'input_origin', 0.05, 'input_scale', 2, 'output_offset', -40, 'output_gain', -1);
  m.mpi_deadzone = struct('model', 'mpi-deadzone', 'q', 0.8, 'r', [0.1 0.2], 'p', [0.3 0.1], ...
                          'g0', 1, 'z', [-0.5 0.25], 'g', [0.2 0.3]);
  m.mpi_asym = struct('model', 'mpi-asym', 'q', 1, 'r', [0.05 0.1 0.2], 'p', [0.3 0.2 0.1], ...
                      'ascending', struct('envelope', 'tanh', 'c', [1 2 0 0]), ...
                      'descending', struct('envelope', 'affine', 'c', [0.8 0]), 'input_limits', [0 0.6]);
end

function failed = check(ok, varargin)
  failed = ~ok;
  if failed
    fprintf('FAIL: %s\n', sprintf(varargin{:}));
  end
end
