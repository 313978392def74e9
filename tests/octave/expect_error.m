function f = expect_error(fn, id, needles)
%EXPECT_ERROR 0 where FN() raises an error with identifier ID whose message contains NEEDLES (a
% text or a cell of texts), else 1 and a line FAIL: ... (the tests of tests/octave).
  if ischar(needles)
    needles = {needles};
  end
  f = 0;
  try
    fn();
    fprintf('FAIL: no error (expected %s: %s)\n', id, strjoin(needles, ', '));
    f = 1;
  catch err
    missing = needles(cellfun(@(n) isempty(strfind(err.message, n)), needles));
    if ~strcmp(err.identifier, id) || ~isempty(missing)
      fprintf('FAIL: got %s: %s (expected %s, mentioning %s)\n', err.identifier, err.message, id, strjoin(missing, ', '));
      f = 1;
    else
      printf('ok   %s: %s\n', err.identifier, err.message);
    end
  end
end
