function test_evaluate()
%TEST_EVALUATE hysteron_evaluate returns what Python's evaluate does besides the metrics
% (outside_input_limits, output_map, clipping_warning, output_map_warning) and the input
% coverage warning, and issues each non-empty warning as hysteron:evaluate.
  fails = 0;
  gpi = struct('model', 'gpi', 'c', [60 4 -0.5 30], 'q', 0.8, 'n', 10, 'rho', 0.4, 'tau', 0.1, 'alpha', 2, ...
               'input_limits', [0 0.6]);
  x = 0.3 * (1 - cos(linspace(0, 8 * pi, 2000)));
  y = hysteron_simulate(gpi, x);
  randn('state', 1);
  noisy = y + 0.05 * randn(size(y));
  % the record as the model predicts it: no warning
  [m, w, id] = evaluate_warned(gpi, x, noisy);
  names = {'rms', 'n', 'outside_input_limits', 'output_map', 'clipping_warning', 'output_map_warning', ...
           'input_coverage_warning'};
  for k = 1:numel(names)
    fails = fails + check_that(isfield(m, names{k}), 'field %s missing', names{k});
  end
  fails = fails + check_that(isempty(w), 'a clean record warns: %s', w);
  fails = fails + check_that(m.outside_input_limits == 0 && isempty(m.input_coverage_warning), 'clean: coverage');
  fails = fails + check_that(abs(m.output_map.gain - 1) < 0.01 && isempty(m.output_map_warning), 'clean: gain %g', ...
                        m.output_map.gain);
  fails = fails + check_that(isempty(m.clipping_warning), 'clean: clipping_warning %s', m.clipping_warning);
  % the output's sign flipped: the map explains it, and says so
  [m, w, id] = evaluate_warned(gpi, x, -noisy);
  fails = fails + check_that(m.output_map.gain < 0 && ~isempty(strfind(m.output_map_warning, 'sign')), ...
                        'flipped: gain %g, warning "%s"', m.output_map.gain, m.output_map_warning);
  fails = fails + check_that(strcmp(id, 'hysteron:evaluate') && strcmp(w, m.output_map_warning), ...
                        'flipped: warning %s "%s"', id, w);
  % the input beyond the model's limits [0 0.6] for half of the record
  [m, w, id] = evaluate_warned(gpi, 2 * x, hysteron_simulate(gpi, 2 * x));
  fails = fails + check_that(m.outside_input_limits > 500 && ~isempty(m.input_coverage_warning), ...
                        'outside: %d samples, warning "%s"', m.outside_input_limits, m.input_coverage_warning);
  fails = fails + check_that(strcmp(id, 'hysteron:evaluate') && ~isempty(strfind(w, 'input_limits')), ...
                        'outside: warning %s "%s"', id, w);
  % the output clips at a sensor's limit (below the least output): scored as recorded, a warning
  lo = min(y) + 0.25 * (max(y) - min(y));
  clipped = max(noisy, lo);
  [m, w, id] = evaluate_warned(gpi, x, clipped);
  fails = fails + check_that(~isempty(strfind(m.clipping_warning, 'clips')), 'clipped: clipping_warning "%s"', ...
                        m.clipping_warning);
  fails = fails + check_that(strcmp(id, 'hysteron:evaluate') && ~isempty(w), 'clipped: warning %s "%s"', id, w);
  [m, w] = evaluate_warned(gpi, x, clipped, 'censored', true);
  fails = fails + check_that(isempty(m.clipping_warning) && m.censored_samples > 0, ...
                        'clipped, censored: %d censored, warning "%s"', m.censored_samples, m.clipping_warning);
  if fails > 0
    error('test_evaluate: %d check(s) failed', fails);
  end
  fprintf('test_evaluate: the extra fields and the warnings are there\n');
end

% hysteron_evaluate and the last warning it issued ('' if none)
function [m, w, id] = evaluate_warned(varargin)
  lastwarn('', '');
  m = hysteron_evaluate(varargin{:});
  [w, id] = lastwarn();
end
