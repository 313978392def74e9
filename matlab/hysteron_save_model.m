function hysteron_save_model(file, model)
%HYSTERON_SAVE_MODEL Write a model to a model file (JSON).
%   HYSTERON_SAVE_MODEL(FILE, MODEL) validates MODEL (a model struct, the JSON text
%   of a model or another model file's name) and writes it to FILE atomically (a
%   temporary file renamed over FILE: a failure leaves FILE untouched). Numbers are
%   written with 17 significant digits, so HYSTERON_LOAD_MODEL reads back the same
%   doubles. The fields units, note, metadata and training are kept. The command line
%   (`hysteron simulate/invert/evaluate --model FILE`), the C++ library and the
%   Python module read the file.
%
%   Example:
%     m = struct('model', 'pi', 'q', 0.4, 'r', [0 0.1 0.25], 'p', [0.3 0.2 0.15], ...
%                'input_limits', [0 0.6], 'note', 'hand-made');
%     hysteron_save_model('pi.json', m);
%
%   See also HYSTERON_LOAD_MODEL, HYSTERON_MODEL_JSON.
  if nargin ~= 2
    error('hysteron:badArgument', 'usage: hysteron_save_model(file, model)');
  end
  hysteron_mex('save', file, model);
end
