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
%     input_coverage_warning where more than 1 % of the samples are outside the input
%                            limits ('' otherwise)
%   and the diagnosis and verdict of `hysteron evaluate` (the same C++), judged against
%   the training error the model's "training" field records (hysteron_fit's model and
%   a file hysteron fit wrote carry it):
%     training               that field (rms, r2, samples), or [] where the model has none
%     output_map_warning     where a sign, unit or zero of the output explains a poor
%                            score, where the model describes the record far worse than
%                            its training record, where the input spans too little of the
%                            model's input range for R^2 to say much, or the input map's
%                            warning where the INPUT is in another zero or unit
%                            (absolute against gauge pressure, kPa against MPa) ('' otherwise)
%     input_map              then: scale, shift (X -> scale * X + shift), rms, r2 and
%                            rms_as_is (the RMS error on X as recorded); [] otherwise
%     useless                true where the model records its training error and predicts
%                            Y worse than its mean (R^2 <= 0) with more than twice that
%                            RMS error, unless X spans less than half the model's input
%                            range and no sign, unit or zero explains it (`hysteron
%                            evaluate` exits 3 there)
%     useless_warning        says so ('' otherwise)
%     stuck_output_warning   where Y's reading sits frozen at one value inside its range
%                            while X moves on: a stuck output sensor ('' otherwise;
%                            its samples are 0-based and half-open, as the CLI's)
%     stuck_input_warning    where X's reading sits frozen at one value inside its range
%                            while Y moves on, then jumps to where X went: a stuck input sensor
%                            ('' otherwise; samples 0-based and half-open)
%     outlier_warning        where samples of X or Y lie far outside the rest: a glitch,
%                            a spike or a sensor's overrange value ('' otherwise; samples
%                            0-based)
%   Each non-empty warning is also issued as a warning with identifier
%   hysteron:evaluate (warning('off', 'hysteron:evaluate') silences them).
%
%   See also HYSTERON_FIT, HYSTERON_SIMULATE.
  if nargin < 3
    error('hysteron:badArgument', 'usage: metrics = hysteron_evaluate(model, x, y, ''range'', [first last])');
  end
  metrics = hysteron_mex('evaluate', model, x, y, hysteron_options('hysteron_evaluate', varargin{:}));
  for f = {'clipping_warning', 'input_coverage_warning', 'output_map_warning', 'stuck_output_warning', ...
           'stuck_input_warning', 'outlier_warning', 'useless_warning'}
    if ~isempty(metrics.(f{1}))
      warning('hysteron:evaluate', '%s', metrics.(f{1}));
    end
  end
end
