function test_rig()
%TEST_RIG The simulated rig runs from Octave: the columns, physics that make sense
% (contraction grows with pressure, a hysteresis loop), reproducible for a seed, and
% the parameters and options act.
  fails = 0;
  t = (1:6000)' * 1e-3;
  p = 0.3 * (1 - cos(2 * pi * 0.2 * t));                 % 0..0.6 MPa, 0.2 Hz, 6 s
  r = hysteron_rig(p, 'seed', 3);
  names = {'t', 'pressure_command_mpa', 'pressure_mpa', 'contraction_mm', 'contraction_measured_mm'};
  for k = 1:numel(names)
    v = r.(names{k});
    fails = fails + check(iscolumn(v) && numel(v) == numel(p) && all(isfinite(v)), '%s: size or values', names{k});
  end
  fails = fails + check(abs(r.t(1) - 1e-3) < 1e-12 && abs(r.t(end) - 6) < 1e-9, 'time axis %g..%g', r.t(1), r.t(end));
  fails = fails + check(isequal(r.pressure_command_mpa, p), 'command column');
  [~, top] = max(p);
  fails = fails + check(r.contraction_mm(top + 200) > r.contraction_mm(1) + 20, ...
                        'contraction at 0.6 MPa %g mm is not above rest %g mm', r.contraction_mm(top + 200), r.contraction_mm(1));
  fails = fails + check(max(r.pressure_mpa) > 0.5 && max(r.pressure_mpa) < 0.65, 'pressure max %g MPa', max(r.pressure_mpa));
  % hysteresis: at 0.3 MPa command the muscle is shorter on the way down than up
  up = find(p > 0.3, 1);
  down = find(p < 0.3 & t > 3, 1);
  fails = fails + check(r.contraction_mm(down) - r.contraction_mm(up) > 1, 'no hysteresis: up %g, down %g mm', ...
                        r.contraction_mm(up), r.contraction_mm(down));
  % reproducible bit for bit; another seed changes the sensor noise
  fails = fails + check(isequal(hysteron_rig(p, 'seed', 3), r), 'the same seed gives another run');
  r4 = hysteron_rig(p, 'seed', 4);
  fails = fails + check(~isequal(r4.contraction_measured_mm, r.contraction_measured_mm), 'another seed gives the same noise');
  % parameters: a lighter load contracts more; the complete parameter struct round-trips
  light = hysteron_rig(p, 'seed', 3, 'params', struct('load', struct('mass', 10)));
  fails = fails + check(light.contraction_mm(top) > r.contraction_mm(top) + 1, 'mass 10 kg: %g mm vs %g mm at 20 kg', ...
                        light.contraction_mm(top), r.contraction_mm(top));
  defaults = hysteron_rig_params();
  fails = fails + check(defaults.load.mass == 20 && isfield(defaults, 'muscle') && isfield(defaults, 'sensors'), 'defaults');
  full = hysteron_rig_params(struct('load', struct('mass', 10)));
  fails = fails + check(full.load.mass == 10 && isequal(full.muscle, defaults.muscle), 'partial parameters');
  fails = fails + check(isequal(hysteron_rig(p, 'seed', 3, 'params', full), light), 'complete struct != partial one');
  % control period: one value per 2 ms
  r2 = hysteron_rig(p(1:100), 'control_period', 2e-3);
  fails = fails + check(abs(r2.t(end) - 0.2) < 1e-9, 'control_period 2e-3: last time %g', r2.t(end));
  if fails > 0
    error('test_rig: %d check(s) failed', fails);
  end
  fprintf('test_rig: all checks passed (max contraction %.2f mm at 0.6 MPa)\n', max(r.contraction_mm));
end

function failed = check(ok, varargin)
  failed = ~ok;
  if failed
    fprintf('FAIL: %s\n', sprintf(varargin{:}));
  end
end
