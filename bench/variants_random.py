#!/usr/bin/env python3
"""Random combined plant variants: rigs nobody tuned anything on (docs/plant.md, "Random
combined variants"). Each of N variants changes 3 to 5 properties at once, drawn uniformly from
plausible ranges (load, damping, hysteresis band and shape, creep, regulator lag, dead time and
band, force map, dead volume, sensor offsets, PWM frequency, valve delays, muscle length).
Deterministic for a seed.

    /usr/bin/python3 bench/variants_random.py [SEED] [N] [--wide] > grid.json
    build/hysteron sweep all --grid grid.json --jobs 2 --out out/random.csv --report out/random.html

--wide draws 3 to 6 properties from wider ranges that reach the extreme and beyond sets'
(docs/plant.md): loads of 2-90 kg, regulators of 20-300 ms, valve and regulator flow, the
band's growth with pressure, sensor noise, muscle radius 6-16 mm, supplies of 4.5-9 bar.
"""
import json
import random
import sys

RANGES = {
    "load.mass": (8, 45), "load.damping": (150, 900),
    "hysteresis.pressure_band": (5000, 30000), "hysteresis.transition_strain": (0.005, 0.012),
    "hysteresis.beta": (0.2, 0.9), "hysteresis.creep_stiffness": (50, 400),
    "regulator.time_constant": (0.02, 0.15), "regulator.dead_time": (0.003, 0.02),
    "regulator.proportional_band": (10000, 50000),
    "muscle.force_620": (1000, 1600), "muscle.dead_volume": (1e-5, 5e-5),
    "sensors.pressure_offset": (-10000, 10000), "sensors.displacement_offset": (-0.002, 0.002),
    "valves.pwm_frequency": (100, 400), "valves.on_delay": (0.0005, 0.003),
    "muscle.rest_length": (0.4, 0.7),
}


WIDE = {
    "load.mass": (2, 90), "load.damping": (50, 2500),
    "hysteresis.pressure_band": (1000, 45000), "hysteresis.transition_strain": (0.003, 0.02),
    "hysteresis.beta": (0.1, 0.95), "hysteresis.creep_stiffness": (0, 600), "hysteresis.creep_time": (0.3, 10),
    "hysteresis.pressure_band_slope": (0, 0.15), "hysteresis.exponent": (1.0, 2.0),
    "regulator.time_constant": (0.02, 0.3), "regulator.dead_time": (0.002, 0.04),
    "regulator.proportional_band": (5000, 80000), "regulator.sonic_conductance": (4e-9, 5e-8),
    "muscle.force_620": (600, 2000), "muscle.dead_volume": (5e-6, 2e-4), "muscle.effective_radius": (0.006, 0.016),
    "sensors.pressure_offset": (-30000, 30000), "sensors.displacement_offset": (-0.01, 0.01),
    "sensors.displacement_noise": (0, 0.0003), "sensors.pressure_noise": (0, 4000),
    "sensors.pressure_time_constant": (0.0005, 0.02),
    "valves.pwm_frequency": (50, 500), "valves.on_delay": (0.0002, 0.005), "valves.sonic_conductance": (2e-9, 2e-8),
    "valves.min_pulse": (0, 0.002),
    "muscle.rest_length": (0.25, 0.9), "air.supply_pressure": (450000, 900000),
}


def draw(seed, n, ranges, most, digits, sensor, prefix):
    """n variants of 3..`most` properties drawn from `ranges`, rounded to `digits`; a muscle
    whose stroke (max contraction 0.25) exceeds the default 0.15 m displacement sensor gets a
    `sensor` m one, as a user would (the rig's validation refuses a stroke beyond its range)."""
    rng = random.Random(seed)
    keys = list(ranges)
    variants = []
    for i in range(n):
        chosen = rng.sample(keys, rng.randint(3, most))
        s = {k: round(rng.uniform(*ranges[k]), digits) for k in chosen}
        if "valves.on_delay" in s:
            # a valve opens within its PWM period (the rig refuses a delay of a period or more):
            # a delay drawn at or beyond the period of the frequency drawn (or the default 200 Hz)
            # is set to 0.8 periods (the draws that ran before are unchanged)
            period = 1.0 / s.get("valves.pwm_frequency", 200.0)
            if s["valves.on_delay"] >= period:
                s["valves.on_delay"] = round(0.8 * period, digits)
            s["valves.off_delay"] = s["valves.on_delay"]
        if s.get("muscle.rest_length", 0.0) * 0.25 > 0.15:
            s["sensors.displacement_range"] = sensor
        variants.append({"name": f"{prefix}{i:02d}", "set": s})
    return variants


def main():
    args = [a for a in sys.argv[1:] if a != "--wide"]
    seed = int(args[0]) if len(args) > 0 else 20261126
    n = int(args[1]) if len(args) > 1 else 14
    if "--wide" in sys.argv[1:]:
        variants = draw(seed, n, WIDE, 6, 9, 0.25, "w")
    else:
        variants = draw(seed, n, RANGES, 5, 6, 0.2, "r")
    json.dump({"variants": variants}, sys.stdout, indent=1)
    sys.stdout.write("\n")


if __name__ == "__main__":
    main()
