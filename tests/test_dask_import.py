"""optdesign.study.cluster.import_distributed, the client's ``import distributed`` with Dask's
YAML configuration read by libyaml's parser: the configuration Dask ends with is the one the
plain import gives (Dask's defaults and a user's configuration file of many YAML forms), Dask's
``yaml.safe_load`` is put back afterwards, a malformed configuration file is still Dask's error
naming the file, and a process that imported ``distributed`` already is left alone.  Each import
runs in a fresh interpreter (``distributed`` is imported once per process)."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

yaml = pytest.importorskip("yaml")
pytest.importorskip("distributed")

ROOT = Path(__file__).resolve().parents[1]

# a user's Dask configuration file with YAML 1.1's scalars (booleans, nulls, numbers in several
# notations, timestamps, quoted and block strings), nesting, lists and anchors
USER_CONFIG = """\
optdesign-test:
  flags: [yes, no, on, off, true, False, ~, null]
  numbers: [1, -2, 0x1f, 0o17, 1_000, 3.25, 1e3, .inf, -.Inf, .nan, 0.1]
  strings: ["a\\tb", 'it''s', plain text, "20ms", 1s, 2026-11-28, 2026-11-28T15:00:00Z]
  block: |
    two
    lines
  folded: >
    one
    line
  base: &base {a: 1, b: [x, y]}
  derived: {<<: *base, c: 3}
distributed:
  admin:
    tick:
      interval: 1s
"""

SCRIPT = """
import json, sys
import yaml
plain, loaders = yaml.safe_load, []
real_load = yaml.load
def load(stream, Loader):
    loaders.append(Loader.__name__)
    return real_load(stream, Loader=Loader)
yaml.load = load
if sys.argv[1] == "plain":
    import distributed
else:
    from optdesign.study.cluster import import_distributed
    if sys.argv[1] == "again":
        import distributed
        yaml.safe_load = "left alone"
    distributed = import_distributed()
import dask
assert distributed is sys.modules["distributed"]
print(json.dumps({"config": json.dumps(dask.config.config, sort_keys=True, default=repr),
                  "restored": yaml.safe_load is plain, "loaders": loaders}))
"""


def imported(how, config_dir):
    env = {**os.environ, "PYTHONPATH": str(ROOT), "DASK_CONFIG": str(config_dir)}
    done = subprocess.run([sys.executable, "-c", SCRIPT, how], capture_output=True, text=True, env=env, cwd=ROOT)
    return done.returncode, done.stdout, done.stderr


@pytest.fixture
def config_dir(tmp_path):
    (tmp_path / "user.yaml").write_text(USER_CONFIG)
    return tmp_path


def test_the_configuration_is_the_plain_imports_and_dasks_loader_is_put_back(config_dir):
    runs = {}
    for how in ("plain", "libyaml"):
        code, out, err = imported(how, config_dir)
        assert code == 0, err
        runs[how] = json.loads(out)
    assert runs["libyaml"]["config"] == runs["plain"]["config"]
    config = json.loads(runs["plain"]["config"])
    assert config["optdesign-test"]["derived"] == {"a": 1, "b": ["x", "y"], "c": 3}   # the user's file was read
    assert config["distributed"]["admin"]["tick"]["interval"] == "1s"
    assert runs["libyaml"]["restored"] and runs["plain"]["restored"]
    assert runs["plain"]["loaders"] == ["SafeLoader"] * len(runs["plain"]["loaders"])
    if getattr(yaml, "CSafeLoader", None) is not None:   # every file Dask read went through libyaml's parser
        assert runs["libyaml"]["loaders"] and set(runs["libyaml"]["loaders"]) == {"CSafeLoader"}
        assert len(runs["libyaml"]["loaders"]) == len(runs["plain"]["loaders"])


def test_a_malformed_configuration_file_is_still_dasks_error_naming_it(tmp_path):
    bad = tmp_path / "broken.yaml"
    bad.write_text("distributed: [unclosed\n")
    code, out, err = imported("libyaml", tmp_path)
    assert code != 0 and "ValueError" in err and str(bad) in err and "malformed" in err, err[-2000:]


def test_a_process_that_imported_distributed_already_is_left_alone(config_dir):
    code, out, err = imported("again", config_dir)
    assert code == 0, err
    got = json.loads(out)
    assert got["loaders"] == ["SafeLoader"] * len(got["loaders"])   # only the plain import's
