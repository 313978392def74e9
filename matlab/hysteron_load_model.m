function model = hysteron_load_model(file)
%HYSTERON_LOAD_MODEL Read a model file (JSON) into a model struct.
%   MODEL = HYSTERON_LOAD_MODEL(FILE) reads and validates the model file FILE
%   (docs/model-files.md) and returns a struct with the keys the library writes
%   (as HYSTERON_MODEL): schema, model ('pi', 'gpi', 'mpi-deadzone', 'mpi-asym',
%   'preisach', 'kp', 'bouc-wen', 'maxwell-slip' or 'rate-pi'), the kind's
%   parameters (q, r, p, c, n, rho, tau, alpha, g0, z, g, ascending, descending;
%   lo, hi, levels, w; kx, kw, sigma; k0, k, delta; dt; defaults filled in),
%   input_limits ([lo hi], -Inf/Inf where
%   unbounded; absent where both sides are), the units map (input_origin,
%   input_scale, output_offset, output_gain) where it is not the identity, and the
%   free-form keys units, note and metadata, and training (the fit's rms, r2,
%   samples), when the file has them. The numbers
%   are the file's doubles exactly.
%
%   A missing or invalid file raises hysteron:modelFile with a message naming the
%   file, the line or the key.
%   See also HYSTERON_SAVE_MODEL, HYSTERON_MODEL, HYSTERON_MODEL_JSON.
  if nargin ~= 1
    error('hysteron:badArgument', 'usage: model = hysteron_load_model(file)');
  end
  model = hysteron_mex('load', file);
end
