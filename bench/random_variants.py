#!/usr/bin/env python3
"""Random plant variants for `hysteron sweep --grid`: rigs that no target or tuning was made on.

Each variant sets 4 parameters of `docs/plant.md`, drawn uniformly from the ranges below
(a reproducible draw: the same seed gives the same file). The sweep's ratios are against the
nominal rig; what to look at is the learning against the compensated loop, the compensated
loop against the baseline, and that every run finishes with its command in 0..0.6 MPa.

Usage: /usr/bin/python3 bench/random_variants.py [--seed 7] [--count 22] [--per 4] > FILE
       build/hysteron sweep all --grid FILE --jobs 2 --out out/random.csv
"""
import argparse
import json
import random

RANGES = {  # parameter: (low, high), SI units as in plant.json
    "load.mass": (5, 50),
    "load.damping": (150, 900),
    "hysteresis.pressure_band": (5e3, 35e3),
    "regulator.time_constant": (0.02, 0.2),
    "regulator.dead_time": (0.002, 0.03),
    "muscle.effective_radius": (0.008, 0.014),
    "muscle.force_620": (1000, 2000),
    "sensors.displacement_offset": (-0.005, 0.005),
    "sensors.pressure_offset": (-15e3, 15e3),
    "sensors.pressure_noise": (200, 3000),
    "sensors.displacement_noise": (5e-6, 1e-4),
    "valves.sonic_conductance": (2.5e-9, 8e-9),
    "muscle.rest_length": (0.4, 0.7),
    "hysteresis.pressure_band_slope": (0, 0.1),
    "air.supply_pressure": (6e5, 8e5),
    "sensors.pressure_time_constant": (1e-3, 1e-2),
    "hysteresis.creep_time": (0.3, 2),
}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--count", type=int, default=22)
    ap.add_argument("--per", type=int, default=4, help="parameters set per variant")
    a = ap.parse_args()
    if not 1 <= a.per <= len(RANGES) or a.count < 1:
        ap.error(f"--per must be in 1..{len(RANGES)} and --count >= 1")
    rng = random.Random(a.seed)
    keys = list(RANGES)
    variants = []
    for i in range(a.count):
        chosen = rng.sample(keys, a.per)
        variants.append({"name": f"r{i}", "set": {k: float("%.4g" % rng.uniform(*RANGES[k])) for k in chosen}})
    print(json.dumps({"variants": variants}, indent=1))


if __name__ == "__main__":
    main()
