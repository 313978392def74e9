function s = hysteron_model(model)
%HYSTERON_MODEL Validate a model and return it as the library writes it.
%   S = HYSTERON_MODEL(MODEL) takes a model struct (possibly with defaults left out,
%   scalars for one-element arrays), the JSON text of a model file ('{...}') or a
%   model file name, checks it as the model file reader does and returns the struct
%   with the keys the library writes to a model file (model_to_json): schema, model
%   and every parameter of the kind (a parameter with a default, such as q, filled
%   in); input_limits only where the model has a bound (-Inf / Inf for an unbounded
%   side); the units map (input_origin, input_scale, output_offset, output_gain) only
%   where it differs from the identity (0, 1, 0, 1); units, note and metadata when
%   given. Use it to convert JSON text to a struct, or to check a hand-written
%   struct; errors (hysteron:badModel) name the key.
%
%   Example:
%     s = hysteron_model('{"model": "pi", "r": [0, 0.1], "p": [0.3, 0.2]}');
%     % s: schema 1, model 'pi', q 0 (the default), r, p; no input_limits (unbounded),
%     % no units map (the identity)
%
%   See also HYSTERON_MODEL_JSON, HYSTERON_LOAD_MODEL, HYSTERON_SAVE_MODEL.
  if nargin ~= 1
    error('hysteron:badArgument', 'usage: s = hysteron_model(model)');
  end
  s = hysteron_mex('model', model);
end
