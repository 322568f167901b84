"""problems/lib_dump_truck_hoist.toml against its independent numpy model
(ref_lib_dump_truck_hoist.py): the global optimum, the certified peak, the drive load at the
start and at the optimum."""
from . import ref_lib_dump_truck_hoist
from .checks import SceneChecks


class TestDumpTruckHoist(SceneChecks):
    ref = ref_lib_dump_truck_hoist
