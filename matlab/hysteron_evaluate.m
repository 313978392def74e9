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
%   See also HYSTERON_FIT, HYSTERON_SIMULATE.
  if nargin < 3
    error('hysteron:badArgument', 'usage: metrics = hysteron_evaluate(model, x, y, ''range'', [first last])');
  end
  metrics = hysteron_mex('evaluate', model, x, y, hysteron_options('hysteron_evaluate', varargin{:}));
end
