function v = hysteron()
%HYSTERON Hysteresis models of pneumatic muscles for MATLAB and Octave (docs/matlab.md).
%   HYSTERON prints this list and the version; V = HYSTERON returns the version.
%
% Models, exact inverses and identification (docs/matlab.md)
%   hysteron_fit         - Identify a model (gpi, pi, mpi-deadzone, mpi-asym, auto) from data.
%   hysteron_simulate    - Run a model forwards: input -> output.
%   hysteron_invert      - Exact inverse: desired output -> input.
%   hysteron_evaluate    - Error metrics of a model on a record.
%
% Model files and structs
%   hysteron_load_model  - Read a model file (JSON) into a struct.
%   hysteron_save_model  - Write a model struct to a model file (JSON).
%   hysteron_model       - Validate a model (struct, JSON text or file) -> model struct.
%   hysteron_model_json  - A model as JSON text.
%
% Simulated rig and loops
%   hysteron_rig         - Run the simulated pneumatic-muscle rig on a pressure command.
%   hysteron_rig_params  - The rig's complete parameter struct.
%   hysteron_loop        - Replay a loop of `hysteron experiment` (result.json) over
%                          recorded signals: the pressure commands it gives.
%
% Gateway
%   hysteron_mex         - The MEX file behind these functions (hysteron_mex('version')).
%
% A model argument is a model struct, the JSON text of a model file or a model file
% name, of any kind the library reads: pi, gpi, mpi-deadzone, mpi-asym, preisach, kp,
% bouc-wen, maxwell-slip, rate-pi (docs/model-files.md); errors have identifiers
% hysteron:* (see docs/matlab.md).
  if nargout > 0
    v = hysteron_mex('version');
  else
    help('hysteron');
    fprintf('hysteron %s\n', hysteron_mex('version'));
  end
end
