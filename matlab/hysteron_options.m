function s = hysteron_options(caller, varargin)
%HYSTERON_OPTIONS Name/value pairs (or one struct) -> options struct (internal helper).
%   S = HYSTERON_OPTIONS(CALLER, 'name1', value1, 'name2', value2, ...) returns a
%   struct with those fields; S = HYSTERON_OPTIONS(CALLER, OPTS) with a struct OPTS
%   returns OPTS. The hysteron_* functions use it; the gateway (hysteron_mex) checks
%   the names and values and raises an error naming an unknown option.
  if numel(varargin) == 1 && (isstruct(varargin{1}) || isempty(varargin{1}))
    s = varargin{1};
    if isempty(s)
      s = struct();
    end
    return;
  end
  if mod(numel(varargin), 2) ~= 0
    error('hysteron:badArgument', '%s: options must be name/value pairs (got %d values)', caller, numel(varargin));
  end
  s = struct();
  for k = 1:2:numel(varargin)
    name = varargin{k};
    if ~ischar(name) || isempty(name)
      error('hysteron:badArgument', '%s: argument %d must be an option name (text)', caller, k);
    end
    s.(name) = varargin{k + 1};
  end
end
