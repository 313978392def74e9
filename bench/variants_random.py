#!/usr/bin/env python3
"""Random combined plant variants: rigs nobody tuned anything on (docs/plant.md, "Random
combined variants"). Each of N variants changes 3 to 5 properties at once, drawn uniformly from
plausible ranges (load, damping, hysteresis band and shape, creep, regulator lag, dead time and
band, force map, dead volume, sensor offsets, PWM frequency, valve delays, muscle length).
Deterministic for a seed.

    /usr/bin/python3 bench/variants_random.py [SEED] [N] > grid.json
    build/hysteron sweep all --grid grid.json --jobs 2 --out out/random.csv --report out/random.html
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


def main():
    seed = int(sys.argv[1]) if len(sys.argv) > 1 else 20261126
    n = int(sys.argv[2]) if len(sys.argv) > 2 else 14
    rng = random.Random(seed)
    keys = list(RANGES)
    variants = []
    for i in range(n):
        chosen = rng.sample(keys, rng.randint(3, 5))
        s = {k: round(rng.uniform(*RANGES[k]), 6) for k in chosen}
        if "valves.on_delay" in s:
            s["valves.off_delay"] = s["valves.on_delay"]
        # A muscle longer than 0.6 m strokes more than the default 0.15 m displacement sensor
        # (max contraction 0.25): give it a 0.2 m sensor, as a user would (the rig's validation
        # refuses a stroke beyond the sensor's range).
        if s.get("muscle.rest_length", 0.0) * 0.25 > 0.15:
            s["sensors.displacement_range"] = 0.2
        variants.append({"name": f"r{i:02d}", "set": s})
    json.dump({"variants": variants}, sys.stdout, indent=1)
    sys.stdout.write("\n")


if __name__ == "__main__":
    main()
