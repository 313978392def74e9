function test_errors()
%TEST_ERRORS Bad input raises a MATLAB error with an identifier hysteron:* and a message
% that says what and where, never a crash; the gateway works normally afterwards.
  fails = 0;
  dir = tempname();
  mkdir(dir);
  cleanup = onCleanup(@() rmdir(dir, 's'));
  gpi = struct('model', 'gpi', 'c', [60 4 -0.5 30], 'q', 0.8, 'n', 10, 'rho', 0.4, 'tau', 0.1, 'alpha', 2);
  x = linspace(0, 0.6, 200);
  y = hysteron_simulate(gpi, x);
  no_tau = rmfield(gpi, 'tau');
  bad_q = gpi; bad_q.q = 'abc';
  nan_q = gpi; nan_q.q = NaN;
  neg_alpha = gpi; neg_alpha.alpha = -1;
  unknown_kind = gpi; unknown_kind.model = 'foo';
  unknown_key = gpi; unknown_key.gain = 2;
  swapped_limits = gpi; swapped_limits.input_limits = [Inf -Inf];  % not unbounded: lo > hi
  inf_lo = gpi; inf_lo.input_limits = [Inf 0.6];
  nan_limit = gpi; nan_limit.input_limits = [NaN 0.6];  % jsondecode('[null, 0.6]')
  sparse_c = gpi; sparse_c.c = sparse([60 4 0 30]);  % a sparse array's data is its non-zeros only
  % mpi-asym with unbounded envelopes: its numerical inverse needs input limits
  asym = struct('model', 'mpi-asym', 'r', 0.1, 'p', 0.2, 'ascending', struct('envelope', 'affine', 'c', [1 0]), ...
                'descending', struct('envelope', 'affine', 'c', [0.8 0]));
  missing = fullfile(dir, 'no_such_model.json');
  broken = fullfile(dir, 'broken.json');
  fid = fopen(broken, 'w'); fprintf(fid, '{"model": "gpi",\n "q": }\n'); fclose(fid);

  % {what, call, identifier, text the message must contain}
  cases = {
    'NaN in simulate input',  @() hysteron_simulate(gpi, [0 0.1 NaN 0.2]), 'hysteron:nonFinite', 'x(3) is NaN'
    'Inf in invert input',    @() hysteron_invert(gpi, [1 Inf]),            'hysteron:nonFinite', 'y(2) is Inf'
    'NaN in fit data',        @() hysteron_fit([x NaN], [y 1]),             'hysteron:nonFinite', 'x(201) is NaN'
    'unknown fit kind',       @() hysteron_fit(x, y, 'model', 'foo'),       'hysteron:badArgument', 'foo'
    'unknown fit option',     @() hysteron_fit(x, y, 'num_operatorz', 3),   'hysteron:badArgument', 'num_operatorz'
    'non-integer option',     @() hysteron_fit(x, y, 'num_operators', 2.5), 'hysteron:badArgument', 'num_operators'
    'bad train range',        @() hysteron_fit(x, y, 'train', [0 10]),      'hysteron:badArgument', 'train'
    'train beyond the data',  @() hysteron_fit(x, y, 'train', [1 1e6]),     'hysteron:fitInvalidInput', ''
    'constant fit input',     @() hysteron_fit(ones(1, 500), 1:500),        'hysteron:fitInvalidInput', ''
    'unequal fit lengths',    @() hysteron_fit(x, y(1:end - 1)),            'hysteron:badArgument', 'same length'
    'rate-pi without dt',     @() hysteron_fit(x, y, 'model', 'rate-pi'),   'hysteron:fitInvalidInput', 'sample'
    'negative sample_time',   @() hysteron_fit(x, y, 'model', 'rate-pi', 'sample_time', -1), 'hysteron:fitInvalidInput', 'sample_time'
    'missing model file',     @() hysteron_load_model(missing),             'hysteron:modelFile', 'no_such_model.json'
    'missing file, simulate', @() hysteron_simulate(missing, x),            'hysteron:modelFile', 'no_such_model.json'
    'broken model file',      @() hysteron_load_model(broken),              'hysteron:modelFile', 'broken.json'
    'missing key',            @() hysteron_simulate(no_tau, x),             'hysteron:badModel', 'tau'
    'wrong type',             @() hysteron_simulate(bad_q, x),              'hysteron:badModel', '"q"'
    'NaN parameter',          @() hysteron_simulate(nan_q, x),              'hysteron:nonFinite', 'model.q'
    'invalid parameter',      @() hysteron_simulate(neg_alpha, x),          'hysteron:badModel', 'alpha'
    'unknown model kind',     @() hysteron_model(unknown_kind),             'hysteron:badModel', 'foo'
    'unknown model key',      @() hysteron_model(unknown_key),              'hysteron:badModel', 'gain'
    'invalid JSON text',      @() hysteron_model('{"model": '),             'hysteron:badModel', 'JSON'
    'model of a wrong class', @() hysteron_simulate(42, x),                 'hysteron:badArgument', 'model'
    'matrix input',           @() hysteron_simulate(gpi, ones(3)),          'hysteron:badArgument', '3x3'
    'complex input',          @() hysteron_simulate(gpi, [1i 2]),           'hysteron:badArgument', 'complex'
    'single input',           @() hysteron_simulate(gpi, single([1 2])),    'hysteron:badArgument', 'single'
    'unknown simulate option',@() hysteron_simulate(gpi, x, 'relaxd', 1),   'hysteron:badArgument', 'relaxd'
    'odd name/value pairs',   @() hysteron_simulate(gpi, x, 'relaxed'),     'hysteron:badArgument', 'pairs'
    'bad limits',             @() hysteron_invert(gpi, y, 'limits', [1 0]), 'hysteron:badArgument', 'limits'
    'mpi-asym without limits',@() hysteron_invert(asym, y),                 'hysteron:error', 'limit'
    'unwritable model file',  @() hysteron_save_model(fullfile(dir, 'no', 'dir', 'm.json'), gpi), 'hysteron:modelFile', 'm.json'
    'unknown rig parameter',  @() hysteron_rig(zeros(1, 10), 'params', struct('load', struct('mas', 1))), 'hysteron:error', 'mas'
    'negative rig mass',      @() hysteron_rig_params(struct('load', struct('mass', -1))), 'hysteron:error', 'mass'
    'NaN rig pressure',       @() hysteron_rig([0 NaN]),                    'hysteron:nonFinite', 'pressure_mpa(2)'
    'missing rig file',       @() hysteron_rig(0, 'params', fullfile(dir, 'rig.json')), 'hysteron:error', 'rig.json'
    'sparse input',           @() hysteron_simulate(gpi, sparse(x)),       'hysteron:badArgument', 'x: a sparse 1x200 array'
    'sparse zeros (5e6)',     @() hysteron_simulate(gpi, sparse(1, 5e6)),  'hysteron:badArgument', 'use full(x)'
    'sparse invert input',    @() hysteron_invert(gpi, sparse(y)),         'hysteron:badArgument', 'use full(x)'
    'sparse fit data',        @() hysteron_fit(x, sparse(y)),              'hysteron:badArgument', 'y: a sparse'
    'sparse evaluate data',   @() hysteron_evaluate(gpi, sparse(x), y),    'hysteron:badArgument', 'x: a sparse'
    'sparse model field',     @() hysteron_simulate(sparse_c, x),          'hysteron:badArgument', 'model.c: a sparse'
    'sparse limits',          @() hysteron_invert(gpi, y, 'limits', sparse([0 0.6])), 'hysteron:badArgument', 'limits'': a sparse'
    'sparse range',           @() hysteron_evaluate(gpi, x, y, 'range', sparse([1 10])), 'hysteron:badArgument', 'range'': a sparse'
    'sparse scalar option',   @() hysteron_fit(x, y, 'num_operators', sparse(5)), 'hysteron:badArgument', 'num_operators'': a sparse'
    'sparse logical option',  @() hysteron_simulate(gpi, x, 'relaxed', sparse(true)), 'hysteron:badArgument', 'relaxed'': a sparse'
    'sparse rig pressure',    @() hysteron_rig(sparse([0 0 0.3])),         'hysteron:badArgument', 'pressure_mpa: a sparse'
    'sparse rig parameter',   @() hysteron_rig_params(struct('load', struct('mass', sparse(10)))), 'hysteron:badArgument', 'mass: a sparse'
    '3-D input',              @() hysteron_simulate(gpi, ones(1, 1, 200)), 'hysteron:badArgument', 'a 1x1x200 double'
    'limits [Inf -Inf]',      @() hysteron_simulate(swapped_limits, x),    'hysteron:badModel', 'input_limits: [Inf -Inf]'
    'limits [Inf 0.6]',       @() hysteron_model(inf_lo),                  'hysteron:badModel', 'lo <= hi'
    'jsondecode null limit',  @() hysteron_simulate(nan_limit, x),         'hysteron:nonFinite', 'input_limits(1) is NaN: use -Inf or Inf'
    'unknown command',        @() hysteron_mex('nope'),                     'hysteron:badArgument', 'nope'
    'no command',             @() hysteron_mex(),                           'hysteron:badArgument', 'command'
    'too many arguments',     @() hysteron_mex('simulate', gpi, x, struct(), 4), 'hysteron:badArgument', 'arguments'
  };
  for i = 1:size(cases, 1)
    [what, call, id, text] = cases{i, :};
    try
      call();
      fails = fails + check(false, '%s: no error', what);
    catch err
      fails = fails + check(strcmp(err.identifier, id), '%s: identifier %s, expected %s (message: %s)', ...
                            what, err.identifier, id, err.message);
      fails = fails + check(strncmp(err.identifier, 'hysteron:', 9), '%s: identifier %s', what, err.identifier);
      fails = fails + check(isempty(text) || ~isempty(strfind(err.message, text)), ...
                            '%s: message "%s" does not mention "%s"', what, err.message, text);
      fprintf('ok: %-24s %-26s %s\n', what, err.identifier, err.message);
    end
  end
  % the gateway still works after all of these
  fails = fails + check(isequal(hysteron_simulate(gpi, x), y), 'simulate after the errors differs');
  % rate-pi is fitted where the record's sample time is given (its rates are per second)
  [rp, rr] = hysteron_fit(x, y, 'model', 'rate-pi', 'sample_time', 1e-3);
  fails = fails + check(strcmp(rp.model, 'rate-pi') && rp.dt == 1e-3 && ~strcmp(rr.status, 'invalid_input'), ...
                        'rate-pi with sample_time: model %s, status %s', rp.model, rr.status);
  if fails > 0
    error('test_errors: %d check(s) failed', fails);
  end
  fprintf('test_errors: all %d error cases raise hysteron:* errors\n', size(cases, 1));
end

function failed = check(ok, varargin)
  failed = ~ok;
  if failed
    fprintf('FAIL: %s\n', sprintf(varargin{:}));
  end
end
