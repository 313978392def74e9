function failed = check_that(ok, varargin)
%CHECK_THAT 1 (and a line FAIL: MESSAGE) where OK is false, else 0: FAILS = FAILS + CHECK_THAT(OK,
% FORMAT, ...) in the tests of tests/octave.
  failed = ~ok;
  if failed
    fprintf('FAIL: %s\n', sprintf(varargin{:}));
  end
end
