function test_help()
%TEST_HELP `help hysteron_xxx` prints each wrapper's help text (usage and options).
  fails = 0;
  expect = {
    'hysteron',            {'hysteron_fit', 'hysteron_invert', 'hysteron_rig', 'hysteron_loop', 'rate-pi', 'hysteron:*'}
    'hysteron_fit',        {'Identify a hysteresis model', 'num_operators', 'hysteron:fitInvalidInput'}
    'hysteron_simulate',   {'forwards', 'relaxed'}
    'hysteron_invert',     {'Exact inverse', 'limits', 'SATURATED'}
    'hysteron_evaluate',   {'Error metrics', 'range'}
    'hysteron_load_model', {'model file', 'input_limits', 'preisach', 'kp', 'bouc-wen', 'maxwell-slip', 'rate-pi'}
    'hysteron_save_model', {'atomically'}
    'hysteron_model',      {'Validate a model', 'only', 'differs from the identity'}
    'hysteron_model_json', {'JSON text'}
    'hysteron_rig',        {'simulated pneumatic-muscle rig', 'contraction_measured_mm', 'seed'}
    'hysteron_rig_params', {'parameter struct'}
    'hysteron_loop',       {'Replay a loop', 'learning run', 'hysteron:error'}
  };
  for i = 1:size(expect, 1)
    text = evalc(['help ' expect{i, 1}]);
    for k = 1:numel(expect{i, 2})
      fails = fails + check(~isempty(strfind(text, expect{i, 2}{k})), 'help %s does not mention "%s":\n%s', ...
                            expect{i, 1}, expect{i, 2}{k}, text);
    end
  end
  % what hysteron_model's help says it returns: the library's keys, defaults filled in, no
  % unbounded input_limits, no identity units map
  s = hysteron_model('{"model": "pi", "r": [0, 0.1], "p": [0.3, 0.2]}');
  fails = fails + check(isequal(sort(fieldnames(s)), sort({'model'; 'p'; 'q'; 'r'; 'schema'})) && s.q == 0, ...
                        'hysteron_model of a pi: fields %s', strjoin(fieldnames(s)', ', '));
  fails = fails + check(strcmp(hysteron(), hysteron_mex('version')), 'hysteron() returns the version');
  fails = fails + check(~isempty(regexp(hysteron_mex('version'), '^\d+\.\d+\.\d+$', 'once')), 'version');
  if fails > 0
    error('test_help: %d check(s) failed', fails);
  end
  fprintf('test_help: help text of %d functions\n', size(expect, 1));
end

function failed = check(ok, varargin)
  failed = ~ok;
  if failed
    fprintf('FAIL: %s\n', sprintf(varargin{:}));
  end
end
