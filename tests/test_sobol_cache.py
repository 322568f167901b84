"""The Sobol starts come from scipy.stats.qmc and are kept in the user's cache folder
(optdesign/design/starts.py: sobol): the cached points are bit for bit scipy's, a damaged cache
file is drawn again rather than trusted, and a warm run does not import scipy.stats."""
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import qmc

from optdesign.design import starts

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def cache(tmp_path, monkeypatch):
    folder = tmp_path / "cache"
    monkeypatch.setenv("OPTDESIGN_CACHE_DIR", str(folder))
    return folder


def scipy_points(d, m, seed):
    """The reference: scipy's scrambled Sobol points, drawn here directly."""
    return qmc.Sobol(d, scramble=True, seed=np.random.default_rng(seed)).random_base2(m)


@pytest.mark.parametrize("d, m, seed", [(3, 11, 0), (5, 8, [0, 1]), (2, 10, [7, 2]), (1, 4, 12345)])
def test_cached_points_equal_fresh_ones(cache, d, m, seed):
    first = starts.sobol(d, m, seed)
    assert len(list(cache.glob("sobol-*.npy"))) == 1
    second = starts.sobol(d, m, seed)
    expected = scipy_points(d, m, seed)
    assert first.tobytes() == expected.tobytes()
    assert second.tobytes() == expected.tobytes()


def test_cache_is_read_not_redrawn(cache, monkeypatch):
    starts.sobol(3, 6, 4)

    def refuse(*args):
        raise AssertionError("drew the points again although the cache holds them")

    monkeypatch.setattr(starts, "_draw_sobol", refuse)
    assert starts.sobol(3, 6, 4).tobytes() == scipy_points(3, 6, 4).tobytes()


def test_each_seed_its_own_entry(cache):
    # the zoom levels draw with seeds [seed, level]: one entry must not answer for another
    seeds = [3, [3, 1], [3, 2]]
    drawn = [starts.sobol(2, 5, s) for s in seeds]
    for s, points in zip(seeds, drawn):
        assert points.tobytes() == scipy_points(2, 5, s).tobytes()
    assert not np.array_equal(drawn[0], drawn[1]) and not np.array_equal(drawn[1], drawn[2])
    assert len(list(cache.glob("sobol-*.npy"))) == 3


def _entry(cache):
    (npy,) = cache.glob("sobol-*.npy")
    return npy, npy.with_suffix(".json")


@pytest.mark.parametrize("damage", ["flip a byte", "truncate", "garbage", "other points", "bad key", "no key file",
                                    "bad json"])
def test_damaged_cache_file_is_redrawn(cache, damage):
    expected = scipy_points(3, 7, 9)
    starts.sobol(3, 7, 9)
    npy, meta = _entry(cache)
    data = npy.read_bytes()
    if damage == "flip a byte":
        i = len(data) - 5
        npy.write_bytes(data[:i] + bytes([data[i] ^ 0x40]) + data[i + 1:])
    elif damage == "truncate":
        npy.write_bytes(data[: len(data) // 2])
    elif damage == "garbage":
        npy.write_bytes(b"not an array")
    elif damage == "other points":   # a whole, valid file of other points, with its key file made to match it
        import hashlib
        import io

        buf = io.BytesIO()
        np.save(buf, expected * 0.5)
        npy.write_bytes(buf.getvalue())
        m = json.loads(meta.read_text())
        m["sha256"] = hashlib.sha256(buf.getvalue()).hexdigest()
        m["key"]["seed"] = 10     # ... but stored under another key
        meta.write_text(json.dumps(m))
    elif damage == "bad key":
        m = json.loads(meta.read_text())
        m["key"]["scipy"] = "0.0"
        meta.write_text(json.dumps(m))
    elif damage == "no key file":
        meta.unlink()
    else:
        meta.write_text("{")
    again = starts.sobol(3, 7, 9)
    assert again.tobytes() == expected.tobytes()
    # and the entry was written again, whole
    npy, meta = _entry(cache)
    assert starts._cached_sobol(npy.stem, json.loads(meta.read_text())["key"]).tobytes() == expected.tobytes()


def test_unwritable_cache_still_draws(tmp_path, monkeypatch):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    monkeypatch.setenv("OPTDESIGN_CACHE_DIR", str(blocker / "cache"))   # under a file: cannot be made
    assert starts.sobol(2, 4, 1).tobytes() == scipy_points(2, 4, 1).tobytes()


def test_space_filling_points_are_scipys(cache):
    """The design box's points as before the cache: lo + (hi - lo) * Sobol(default_rng(seed))."""

    class Box:
        lower = np.array([0.5, -2.0, 10.0])
        upper = np.array([1.5, 2.0, 30.0])
        start = np.array([1.0, 0.0, 20.0])

    for _ in range(2):   # drawn, then from the cache
        x = starts.space_filling(Box, 100, 5)
        u = scipy_points(3, 7, 5)[:100]
        np.testing.assert_array_equal(x, Box.lower + (Box.upper - Box.lower) * u)


def test_warm_plan_does_not_import_scipy_stats(cache):
    """A second process planning the same starts reads the cache and never imports scipy.stats."""
    code = ("import sys, optdesign\n"
            "from optdesign.design.problem import DesignProblem\n"
            "from optdesign.design.starts import plan_starts\n"
            "pb = DesignProblem(optdesign.load('problems/lib_excavator_boom.toml'))\n"
            "p = plan_starts(pb, 20, 0)\n"
            "print(p.points.sum().hex(), 'scipy.stats' in sys.modules)\n")
    env = dict(os.environ, PYTHONPATH=str(ROOT), OPTDESIGN_CACHE_DIR=str(cache))
    runs = [subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True, text=True,
                           check=True).stdout.split() for _ in range(2)]
    assert runs[0][1] == "True"           # drew the points: imported scipy.stats
    assert runs[1] == [runs[0][0], "False"]   # the same starts, without scipy.stats
