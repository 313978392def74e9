function out = hysteron_loop(result, run, model, reference_m, measured_m, pressure_mpa)
%HYSTERON_LOOP Replay a loop that `hysteron experiment` found over recorded signals.
%   OUT = HYSTERON_LOOP(RESULT, RUN, MODEL, REFERENCE_M, MEASURED_M, PRESSURE_MPA)
%   builds the loop of one tracking run of an experiment's result.json ("controller":
%   inverse feedforward + PID, the open loop with its pressure loop, or the cascade on
%   switching valves; docs/deploy.md) on MODEL and steps it, sample by sample from rest,
%   as a real-time target would: for each sample the reference REFERENCE_M(k) [m], the
%   contraction sensor MEASURED_M(k) [m] and the pressure sensor PRESSURE_MPA(k) [MPa]
%   (not needed, [] allowed, for feedforward_pid). OUT is a struct:
%     loop          'feedforward_pid', 'open_loop' or 'cascade_pwm'
%     command_mpa   the pressure command [MPa] (the cascade: its desired pressure p_d)
%     duty          the cascade's PWM duty in [-1, 1] (0 for the others)
%     preview_m     the reference the feedforward was fed (the run's shaper and lead)
%   shaped like REFERENCE_M.
%   Runs whose loop this does not replay are refused (hysteron:error): a learning run
%   (its iterative learning adds a correction learnt period by period: replay it with the
%   C ABI's hysteron_loop_params_from_file + hysteron_ilc_*, or generate it with
%   `hysteron export --loop result.json --run learning.REFERENCE`) and an adaptive run
%   (its inverse is re-identified online).
%
%   RESULT is a result.json file name (`hysteron experiment NAME --out DIR`), or JSON
%   text of a result.json or of one "controller". RUN is 'VARIANT' for an experiment with
%   one reference ('compensated'), 'VARIANT.REFERENCE' for one with several
%   ('compensated.triangle'), '' for a controller's text: the faithful, compensated and
%   baseline runs (not the learning or adaptive ones, above). MODEL is the model the run
%   inverts: DIR/best_model.json for the compensated loop, DIR/model.json for the
%   faithful one, result.json's baseline_model for the baseline (a model struct, JSON
%   text or file name; jsondecode(fileread(RESULT)).baseline_model).
%   Fed a run's own tracking CSV, it commands what the run commanded: a check of the
%   loop before it drives a muscle. The same as the C ABI's hysteron_loop_params_from_file
%   + hysteron_*_create + hysteron_*_step, and Python's hysteron.controller_from.
%
%   Example:
%     d = 'out/mpi-pwm';        % hysteron experiment mpi-pwm --out out/mpi-pwm
%     c = csvread(fullfile(d, 'tracking_compensated_triangle.csv'), 1, 0);
%     % columns: t_s, reference_mm, measured_mm, actual_mm, pressure_command_mpa,
%     %          pressure_mpa, pwm_duty, pressure_measured_mpa
%     o = hysteron_loop(fullfile(d, 'result.json'), 'compensated.triangle', ...
%                       fullfile(d, 'best_model.json'), c(:,2)/1e3, c(:,3)/1e3, c(:,8));
%     max(abs(o.command_mpa - c(:,5)))      % ~1e-15
%
%   Errors: hysteron:badArgument (no such run: the message names the runs there are; a
%   missing key; sizes), hysteron:error (a learning or adaptive run, see above),
%   hysteron:nonFinite, hysteron:badModel, hysteron:modelFile.
%   See also HYSTERON_INVERT, HYSTERON_RIG.
  if nargin < 5
    error('hysteron:badArgument', ...
          'usage: out = hysteron_loop(result, run, model, reference_m, measured_m, [pressure_mpa])');
  end
  if nargin < 6
    pressure_mpa = [];
  end
  out = hysteron_mex('loop', result, run, model, reference_m, measured_m, pressure_mpa);
end
