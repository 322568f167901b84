"""Reading the drive-sizing tables of a scene file: [profiles], [[cases]], [duty], [gearbox],
[[motors]] and [cylinder] (the rest is read by :mod:`optdesign.scene.file`, which calls
:func:`read_sizing`).  Only the shape of the tables is checked here (unknown keys with the near
miss, missing names, lists); the items check their values and
:mod:`optdesign.scene.validate_cases` the cross references."""
from __future__ import annotations

from .cases import CASE_KEYS, Duty, read_case, read_profile, read_step
from .train import CYLINDER_KEYS, GEARBOX_KEYS, MOTOR_KEYS, Cylinder, Gearbox, Motor
from .where import Where, fail, show

SIZING_KEYS = ("profiles", "cases", "duty", "gearbox", "motors", "cylinder")


def read_sizing(reader, data) -> dict:
    """The Scene keyword arguments of the sizing tables present in ``data`` (the whole TOML
    document); ``reader`` is the file reader (for its key checks)."""
    out = {}
    if "profiles" in data:
        profiles = data["profiles"]
        if not isinstance(profiles, dict):
            fail(Where("profiles"), f"expected a table of named profiles, e.g. [profiles.luff], found {show(profiles)}")
        out["profiles"] = [read_profile(name, spec) for name, spec in profiles.items()]
    if "cases" in data:
        out["cases"] = reader.array("cases", data["cases"], CASE_KEYS, read_case)
    if "duty" in data:
        reader.check_keys(Where("duty"), data["duty"], ("cycle",))
        cycle = data["duty"].get("cycle")
        if not isinstance(cycle, list):
            fail(Where("duty", key="cycle"), f"expected a list of steps, e.g. cycle = [\"raise\", {{ dwell = 10 }}, "
                                             f"\"lower\"], found {show(cycle)}")
        out["duty"] = Duty(tuple(read_step(item, i) for i, item in enumerate(cycle)))
    if "gearbox" in data:
        reader.check_keys(Where("gearbox"), data["gearbox"], GEARBOX_KEYS)
        out["gearbox"] = Gearbox(data["gearbox"].get("ratio"), data["gearbox"].get("efficiency"))
    if "motors" in data:
        if isinstance(data["motors"], list) and not data["motors"]:
            fail(Where("", key="motors"), "the motor catalogue is empty; give at least one [[motors]] entry (name, inertia, "
                                  "rated_torque, peak_torque, max_speed) or leave the key out")
        out["motors"] = reader.array("motors", data["motors"], MOTOR_KEYS, _motor)
    if "cylinder" in data:
        reader.check_keys(Where("cylinder"), data["cylinder"], CYLINDER_KEYS)
        out["cylinder"] = Cylinder(*(data["cylinder"].get(k) for k in CYLINDER_KEYS))
    return out


def _motor(data):
    return Motor(data.get("name"), *(data.get(k) for k in MOTOR_KEYS[1:]))
