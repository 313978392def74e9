function s = hysteron_model(model)
%HYSTERON_MODEL Validate a model and return it as a complete model struct.
%   S = HYSTERON_MODEL(MODEL) takes a model struct (possibly with defaults left out,
%   scalars for one-element arrays), the JSON text of a model file ('{...}') or a
%   model file name, checks it as the model file reader does and returns the struct
%   with every key as the library writes it (model_to_json: defaults filled in,
%   the units map explicit). Use it to convert JSON text to a struct, or to check a
%   hand-written struct; errors (hysteron:badModel) name the key.
%
%   Example:
%     s = hysteron_model('{"model": "pi", "r": [0, 0.1], "p": [0.3, 0.2]}');
%
%   See also HYSTERON_MODEL_JSON, HYSTERON_LOAD_MODEL, HYSTERON_SAVE_MODEL.
  if nargin ~= 1
    error('hysteron:badArgument', 'usage: s = hysteron_model(model)');
  end
  s = hysteron_mex('model', model);
end
