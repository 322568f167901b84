"""problems/lib_excavator_boom.toml against its independent numpy model
(ref_lib_excavator_boom.py): the global optimum, the certified peak, the drive load at the
start and at the optimum."""
from . import ref_lib_excavator_boom
from .checks import SceneChecks


class TestExcavatorBoom(SceneChecks):
    ref = ref_lib_excavator_boom
