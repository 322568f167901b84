"""problems/lib_scissor_lift.toml against its independent numpy model (ref_lib_scissor_lift.py):
the global optimum, the certified peak, the drive load at the start and at the optimum."""
from . import ref_lib_scissor_lift
from .checks import SceneChecks


class TestScissorLift(SceneChecks):
    ref = ref_lib_scissor_lift
