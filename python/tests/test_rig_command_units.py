"""PamRig.step and run_pressure take MPa (gauge): a command in pascals (300000.0 for 0.3 MPa) used to run
silently at the supply's limit. The mirror of reset_at_pressure's guard (Pa, refusing MPa given as Pa)."""
import numpy as np
import pytest

import hysteron


def test_step_refuses_a_command_in_pascals():
    rig = hysteron.PamRig()
    with pytest.raises(hysteron.Error,
                       match=r"PamRig.step: pressure_command = 300000: the unit is MPa \(gauge\), not Pa "
                             r"\(for 300000 Pa give 0.3\); the regulator's commands are 0 \.\. 1 MPa \(regulator.max_command\) "
                             r"and the pressure stays below the supply's 0.6 MPa gauge"):
        rig.step(300000.0)
    with pytest.raises(hysteron.Error, match=r"pressure_command = 10: the unit is MPa"):
        rig.step(10.0)
    assert rig.time == 0.0  # nothing ran
    # MPa as documented, and a command beyond the supply (a controller's saturating output) is clamped as before
    o = rig.step(0.3)
    assert o["ok"] and rig.time > 0
    rig.step(0.9)
    rig.step(-0.1)


def test_run_pressure_refuses_a_profile_in_pascals():
    rig = hysteron.PamRig()
    with pytest.raises(hysteron.Error, match=r"PamRig.run_pressure: profile\[2\] = 300000: the unit is MPa"):
        rig.run_pressure(np.array([0.1, 0.2, 3e5]))
    assert rig.time == 0.0
    r = rig.run_pressure(np.array([0.1, 0.2, 0.3]))
    assert len(r["t"]) == 3
