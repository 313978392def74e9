function [model, report] = hysteron_fit(x, y, varargin)
%HYSTERON_FIT Identify a hysteresis model from a measured input/output record.
%   [MODEL, REPORT] = HYSTERON_FIT(X, Y) fits a GPI model (n = 10 operators) to the
%   input X and the measured output Y (real, finite vectors of equal length) by
%   Levenberg-Marquardt (GPI paper, Eq. 12), as `hysteron fit` on the command line.
%   [MODEL, REPORT] = HYSTERON_FIT(X, Y, 'name', value, ...) sets options:
%     model               'gpi' (default), 'pi', 'mpi-deadzone', 'mpi-asym', 'preisach',
%                         'kp', 'bouc-wen', 'maxwell-slip', 'rate-pi' (needs sample_time)
%                         or 'auto' (every kind fitted, the best on a hold-out chosen)
%     num_operators       n (default 10)
%     num_dead_zones      mpi-deadzone: dead zones (default 4)
%     initial_state       'virgin' (default) or 'relaxed'
%     train               [first last]: samples in the cost (1-based, inclusive; last
%                         may be Inf); the model is still simulated from sample 1
%     huber_delta         > 0: Huber loss threshold (output units); 0: least squares
%     num_starts          initial guesses refined (default 2)
%     num_threads         threads refining them (0: one per core; the result is the same)
%     seed                seed of the start jitter (default 0)
%     max_iterations      LM iterations per start (default 200)
%     min_slope           minimum slope relative to span(y)/span(x) (default 0.02)
%     sample_time         the record's sample time in s (rate-pi's dt; its rates are
%                         per second); required for 'rate-pi', checked by no other kind
%     censor_passes       an output that clips (a sensor's limit) is fitted as censored
%                         data over this many refits (default 2; 0: as recorded)
%     fix_scale, free_weights, compute_covariance, stall_iterations,
%     stall_tolerance, holdout_fraction, poor_fit_ratio   (docs/identification.md)
%     report              name of a self-contained HTML report to write (plots,
%                         parameters, errors), with
%     input_axis, output_axis   {label, unit} of its plots, e.g. {'Pressure', 'kPa'}
%   An options struct may be given instead of the pairs.
%
%   MODEL is the fitted model struct (the model-file keys, docs/model-files.md), [] if
%   the fit produced none. REPORT is a struct: status ('converged', 'no_convergence',
%   'failed', 'poor_fit'), ok, message, model_kind, parameters (struct array: name,
%   value, std_error, held, at_bound), train and reference metrics (rms, max, mae,
%   rms_percent_span, r2, n), inverse, warnings, fault_runs (the runs the sensor-fault
%   warnings name: struct array of rows, [first last] 1-based, and column, 'input' or
%   'output'; [] where none), fault_free_train (where there are fault_runs: [first last],
%   1-based, the longest stretch of the training range free of them, to pass as 'train';
%   [] otherwise), candidates ('auto'), costs,
%   iterations, time_s and report (the text the command line prints).
%   A status other than 'converged' gives a warning (identifier hysteron:fitStatus).
%
%   Example:
%     d = dlmread('festo10mm_20cm_test8.csv', ',');
%     [m, r] = hysteron_fit(d(:, 2), d(:, 1), 'model', 'gpi', 'num_operators', 10);
%     disp(r.report); hysteron_save_model('gpi.json', m);
%
%   Errors: hysteron:fitInvalidInput (data or options refused: too few samples, a
%   constant record, ...), hysteron:nonFinite (NaN or Inf in X or Y),
%   hysteron:badArgument (an unknown option, a wrong type).
%   See also HYSTERON_SIMULATE, HYSTERON_INVERT, HYSTERON_SAVE_MODEL.
  if nargin < 2
    error('hysteron:badArgument', 'usage: [model, report] = hysteron_fit(x, y, ''name'', value, ...)');
  end
  [model, report] = hysteron_mex('fit', x, y, hysteron_options('hysteron_fit', varargin{:}));
  if ~strcmp(report.status, 'converged')
    warning('hysteron:fitStatus', 'hysteron_fit: status %s: %s', report.status, report.message);
  end
end
