"""problems/lib_wheel_loader_arm.toml against its independent numpy model
(ref_lib_wheel_loader_arm.py): the global optimum, the certified peak, the drive load at the
start and at the optimum."""
from . import ref_lib_wheel_loader_arm
from .checks import SceneChecks


class TestWheelLoaderArm(SceneChecks):
    ref = ref_lib_wheel_loader_arm
