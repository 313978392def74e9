function metrics = hysteron_evaluate(model, x, y, varargin)
%HYSTERON_EVALUATE Error metrics of a model on a measured record.
%   M = HYSTERON_EVALUATE(MODEL, X, Y) simulates MODEL over X from its start and
%   returns the errors against Y: a struct with rms, max, mae, rms_percent_span,
%   r2 and n (number of samples scored).
%   M = HYSTERON_EVALUATE(MODEL, X, Y, 'range', [first last], 'initial_state',
%   'relaxed') scores samples first..last only (1-based, inclusive; the model is
%   still simulated from the first sample) and starts at rest at X(1).
%   M = HYSTERON_EVALUATE(..., 'censored', true): where Y clips (a sensor's limit,
%   detected from the record), a sample at the limit that the model puts beyond it is
%   scored as met (censored data, as the fit treats it); M.censored_samples counts them.
%   The same as `hysteron evaluate` on the command line, which scores censored by
%   default (--uncensored: as recorded); here, as in Python, only when asked.
%
%   M also has, as Python's evaluate:
%     outside_input_limits   samples of the range whose input lies outside the model's
%                            input_limits by more than 2 % of their span (the model
%                            extrapolates there)
%     output_map             Y ~ gain * prediction + offset on the range: gain, offset,
%                            r2, r2_mapped, rms, rms_mapped, span (NaN where undefined)
%     clipping_warning       where Y clips and 'censored' is false: how many samples
%                            `hysteron evaluate` would not count as errors ('' otherwise)
%     output_map_warning     where the prediction scores poorly or the map explains the
%                            errors (a flipped sign, a unit, a zero) ('' otherwise)
%     input_coverage_warning where more than 1 % of the samples are outside the input
%                            limits ('' otherwise)
%   Each non-empty warning is also issued as a warning with identifier
%   hysteron:evaluate (warning('off', 'hysteron:evaluate') silences them).
%
%   See also HYSTERON_FIT, HYSTERON_SIMULATE.
  if nargin < 3
    error('hysteron:badArgument', 'usage: metrics = hysteron_evaluate(model, x, y, ''range'', [first last])');
  end
  metrics = hysteron_mex('evaluate', model, x, y, hysteron_options('hysteron_evaluate', varargin{:}));
  for f = {'clipping_warning', 'output_map_warning', 'input_coverage_warning'}
    if ~isempty(metrics.(f{1}))
      warning('hysteron:evaluate', '%s', metrics.(f{1}));
    end
  end
end
