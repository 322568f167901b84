"""Time weights shared between case models (model/duty.shared_weights): the cases of one profile
and direction, and every problem of a scene made again (a motor catalogue's motors), take the
weights computed once.  They are shared only between profiles of the same numbers: a case of
another profile, or of the same profile in the other direction, fed the very same nodes, times
and speeds, gets its own weights, each the one computed afresh by the rule itself; and a
catalogue's motors (which differ in their limits, not their profiles) take each other's."""
from __future__ import annotations

from pathlib import Path

import numpy as np

import optdesign
from optdesign.design.catalogue import motor_order, with_motor
from optdesign.design.problem import DesignProblem
from optdesign.kinematics.mechanism import Mechanism
from optdesign.model import duty
from optdesign.model.cases import CaseModel
from optdesign.scene.file import loads

CRANE = Path(__file__).resolve().parents[1] / "problems" / "crane_luffing_drive.toml"


def _case_models(scene):
    mech = Mechanism(scene)
    return {c.name: CaseModel(mech, c) for c in scene.cases}


def test_only_profiles_of_the_same_numbers_share_weights():
    text = CRANE.read_text().replace('deceleration = "0.25 deg"', 'deceleration = "0.5 deg"')   # not symmetric
    assert '"0.5 deg"' in text
    scene, quicker = loads(text), loads(text.replace('acceleration = "0.25 deg"', 'acceleration = "0.3 deg"'))
    mine, other = _case_models(scene), _case_models(quicker)
    begin, end = mine["in, rated load"].profile.s_begin, mine["in, rated load"].profile.s_end
    nodes = np.linspace(begin, end, 41)
    values = {"t": mine["in, rated load"].profile.times(nodes), "sd": np.ones(len(nodes))}   # the same for all
    duty._SHARED.clear()
    models = (mine["in, rated load"], mine["test load"], mine["out, rated load"], other["in, rated load"])
    got = [duty.CaseTimes.of(cm, nodes, dict(values)).weights for cm in models]
    fresh = [duty.time_weights(nodes, values["t"], cm.profile) for cm in models]
    for g, f in zip(got, fresh):
        assert np.array_equal(g, f)
    # the three profiles differ (else the test shows nothing), the two cases luffing in do not
    assert not np.array_equal(fresh[0], fresh[2]) and not np.array_equal(fresh[0], fresh[3])
    assert np.array_equal(fresh[0], fresh[1])
    assert len(duty._SHARED) == 3   # in (twice), out, the quicker in: three sets computed


def test_a_catalogues_motors_share_their_profiles_weights():
    scene = optdesign.load(CRANE)
    small, large = (with_motor(scene, m) for m in motor_order(scene)[1:3])
    duty._SHARED.clear()
    first = DesignProblem(small)
    from optdesign.design.cycle_certify import rule_rms_grids

    rule_rms_grids(first, first.start, None)
    kept = len(duty._SHARED)
    second = DesignProblem(large)
    fine, coarse = rule_rms_grids(second, second.start, None)
    assert len(duty._SHARED) == kept > 0   # every weight of the second motor's taken from the first's
    duty._SHARED.clear()                   # and they are the numbers its own cases give alone
    alone = DesignProblem(large)
    assert rule_rms_grids(alone, alone.start, None) == [fine, coarse]
    assert len(duty._SHARED) == kept
    # the motors' own data stays theirs: the RMS of the motor torque (rotor inertia) differs
    assert rule_rms_grids(first, first.start, None)[0]["motor_torque"] != fine["motor_torque"]
