function text = hysteron_model_json(model)
%HYSTERON_MODEL_JSON A model as the JSON text of a model file.
%   TEXT = HYSTERON_MODEL_JSON(MODEL) validates MODEL (a model struct, JSON text or a
%   model file name) and returns the model file's JSON text (docs/model-files.md),
%   e.g. to hand it to the C ABI (hysteron_model_load_json) or another program.
%
%   See also HYSTERON_MODEL, HYSTERON_SAVE_MODEL.
  if nargin ~= 1
    error('hysteron:badArgument', 'usage: text = hysteron_model_json(model)');
  end
  text = hysteron_mex('model_json', model);
end
