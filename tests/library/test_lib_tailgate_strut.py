"""problems/lib_tailgate_strut.toml against its independent numpy model
(ref_lib_tailgate_strut.py): the global optimum, the certified peak, the drive load (hand
torque) at the start and at the optimum, and the hold-open ramp: its maximum over the stroke
is its value at full opening (so that the row is the end condition the scene means)."""
import numpy as np

from . import ref_lib_tailgate_strut
from .checks import SceneChecks, optimum


class TestTailgateStrut(SceneChecks):
    ref = ref_lib_tailgate_strut

    def test_hold_open_ramp_is_the_end_condition(self):
        result, _ = optimum(self.path)
        assert result.success, (result.status, result.message)
        pb = self.ref.problem()
        for design in (pb.scene.start(), result.design):
            x = np.array([design[n] for n in pb.names])
            value, where = pb.stroke_extreme(x, "hold", +1)
            assert abs(where - pb.s1) <= 1e-9, (design, where)
