"""The study's validity recording (optdesign/study/validity.py) in threads: studies made in
several threads at once each record their own scene's checks, and the expressions module's
``evaluate`` is the original again once every recording has ended."""
from __future__ import annotations

import threading

import optdesign
from optdesign.scene import expressions
from optdesign.scene.expressions import parse
from optdesign.study.validity import recorded_checks


def test_another_threads_evaluations_are_not_recorded():
    other = parse("2 * k + 1", "other thread")

    def build():   # while this thread records, another thread evaluates an expression of its own
        t = threading.Thread(target=lambda: expressions.evaluate(other, {"k": 1.0}))
        t.start()
        t.join()
        expressions.evaluate(parse("m + 1", "this thread"), {"m": 2.0})

    calls = recorded_checks(build)
    assert [e.source for e, _ in calls] == ["m + 1"]


def test_overlapping_recordings_leave_evaluate_as_it_was():
    original = expressions.evaluate
    b_started = threading.Event()
    out = {}

    def build_b():
        b_started.set()
        expressions.evaluate(parse("b + 1", "b"), {"b": 1.0})

    def record_b():
        out["b"] = recorded_checks(build_b)

    def build_a():   # a second study's recording starts while this one records
        thread_b = threading.Thread(target=record_b)
        thread_b.start()
        out["thread"] = thread_b
        b_started.wait(0.3)   # (with the lock, b waits for this recording to end)
        expressions.evaluate(parse("a + 1", "a"), {"a": 1.0})

    out["a"] = recorded_checks(build_a)
    out["thread"].join()
    assert expressions.evaluate is original
    assert [e.source for e, _ in out["a"]] == ["a + 1"]
    assert [e.source for e, _ in out["b"]] == ["b + 1"]


def test_two_studies_made_in_threads_at_once_match_one_made_alone(tmp_path):
    from optdesign.study import Study, grid

    scene = optdesign.load(__import__("pathlib").Path(__file__).resolve().parents[1] / "problems" / "truck_crane.toml")

    def cases(label):
        study = Study(scene, [grid("mB", 500, 800, 3), grid("mP", 500, 3000, 4)], mode="analyse")
        return study._all_valid, len(study.cases())

    alone = cases("alone")
    assert alone == (True, 12)   # the mass axes: valid at their corners
    found, errors = {}, []

    def make(k):
        try:
            found[k] = cases(k)
        except Exception as exc:   # pragma: no cover - reported below
            errors.append(exc)

    threads = [threading.Thread(target=make, args=(k,)) for k in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors and all(found[k] == alone for k in range(4))
    assert expressions.evaluate.__module__ == "optdesign.scene.expressions"
