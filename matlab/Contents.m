% hysteron: hysteresis models of pneumatic muscles for MATLAB and Octave.
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
%   hysteron_model       - Validate a model (struct, JSON text or file) -> complete struct.
%   hysteron_model_json  - A model as JSON text.
%
% Simulated rig
%   hysteron_rig         - Run the simulated pneumatic-muscle rig on a pressure command.
%   hysteron_rig_params  - The rig's complete parameter struct.
%
% Gateway
%   hysteron_mex         - The MEX file behind these functions (hysteron_mex('version')).
