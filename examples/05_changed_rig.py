"""A rig that changed after its identification (docs/plant.md, "Identified on the nominal
rig"): gpi-pid identified and tuned on the nominal rig, then tracking on the same rig with the
load damping halved (400 -> 200 N s/m), as `hysteron sweep gpi-pid --vary load.damping=200
--identify-on-base`; beside it the same change re-identified and re-tuned on the changed rig.
Prints the RMS error of each variant kind. Fails unless, on the changed rig not re-tuned, the
learning loop ends below the compensated loop and below the baseline, the compensated loop
(whose limit-cycle guard cuts the gains that ring there, docs/control.md section 2) ends below the
baseline too, and re-tuning brings the compensated loop below its baseline."""
import sys

import hysteron

kw = dict(vary=["load.damping=200"], learning_periods=4, jobs=2)
changed = hysteron.run_sweep("gpi-pid", identify_on_base=True, **kw)  # tuned on the nominal rig
retuned = hysteron.run_sweep("gpi-pid", **kw)                          # tuned on the changed rig


def rms(doc):
    run = next(r for r in doc["runs"] if r["variant"] == "load.damping=200")
    assert run["ok"], run
    return {t["kind"]: t["rms_error_mm"] for t in run["tracking"]}


a, b = rms(changed), rms(retuned)
print(f"{'kind':<12} {'not re-tuned':>13} {'re-tuned':>9}   RMS [mm], load damping 200 N s/m")
for kind in a:
    print(f"{kind:<12} {a[kind]:>13.3f} {b[kind]:>9.3f}")
ok = (a["learning"] < a["compensated"] and a["learning"] < a["baseline"] and a["compensated"] < a["baseline"]
      and b["compensated"] < b["baseline"])
if not ok:
    print("FAIL: expected learning below compensated and baseline on the changed rig, the compensated loop "
          "below its baseline there, and the re-tuned compensated loop below its baseline")
    sys.exit(1)
