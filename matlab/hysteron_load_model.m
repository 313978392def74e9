function model = hysteron_load_model(file)
%HYSTERON_LOAD_MODEL Read a model file (JSON) into a model struct.
%   MODEL = HYSTERON_LOAD_MODEL(FILE) reads and validates the model file FILE
%   (docs/model-files.md) and returns a struct whose fields are the file's keys:
%   model ('pi', 'gpi', 'mpi-deadzone', 'mpi-asym'), the parameters (q, r, p, c,
%   n, rho, tau, alpha, g0, z, g, ascending, descending), input_limits ([lo hi],
%   -Inf/Inf where unbounded), the units map (input_origin, input_scale,
%   output_offset, output_gain) and the free-form keys units, note, metadata and training
%   when the file has them. The numbers are the file's doubles exactly.
%
%   A missing or invalid file raises hysteron:modelFile with a message naming the
%   file, the line or the key.
%   See also HYSTERON_SAVE_MODEL, HYSTERON_MODEL, HYSTERON_MODEL_JSON.
  if nargin ~= 1
    error('hysteron:badArgument', 'usage: model = hysteron_load_model(file)');
  end
  model = hysteron_mex('load', file);
end
