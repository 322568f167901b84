"""A compiled library's cache key holds the text of our code that writes its C
(compiled.external's ``code``; the blocked stroke evaluators pass model/blocked_c.py and
model/blocked.py): a changed writer compiles anew instead of loading the library an older
writer made, which would give the older writer's numbers under the new code."""
from __future__ import annotations

import os

import casadi as ca
import pytest

from optdesign.model import blocked, blocked_c, compiled
from test_compiled import cache  # noqa: F401  (the fixture: a fresh cache folder, compiling at once)

pytestmark = pytest.mark.skipif(compiled.shutil.which(os.environ.get("CC", "gcc")) is None,
                                reason="no C compiler on this machine")


def test_a_changed_writer_is_compiled_anew(cache, tmp_path):
    """The same graph, its C written by a 'writer' whose text (a file) says the factor it writes
    into the C: after the file changes, the library must be the new writer's (x * 3), not the
    cached one of the old writer (x * 2)."""
    x = ca.SX.sym("x")
    func = ca.Function("f", [x], [2 * x])
    writer = tmp_path / "writer.py"

    def source(name):
        factor = writer.read_text().strip()
        return ("typedef long long int casadi_int;\n"
                "#ifdef __cplusplus\nextern \"C\" {\n#endif\n"
                f"int {name}(const double** arg, double** res, casadi_int* iw, double* w, int mem) "
                f"{{ if (res[0]) res[0][0] = {factor} * arg[0][0]; return 0; }}\n"
                f"casadi_int {name}_n_in(void) {{ return 1; }}\n"
                f"casadi_int {name}_n_out(void) {{ return 1; }}\n"
                "#ifdef __cplusplus\n}\n#endif\n")

    def value():
        made = compiled.external(func, "optdesign_writer_test", source, wait=True, code=(writer,))
        assert made is not None, "not compiled"
        return float(made(1.5))

    writer.write_text("2.0")
    assert value() == 3.0
    writer.write_text("3.0")
    assert value() == 4.5   # the old key would have loaded the library that doubles
    writer.write_text("2.0")
    assert value() == 3.0   # and the first one is still found under its own key


def test_the_blocked_evaluators_key_holds_their_writer(monkeypatch):
    """stroke_evaluator's entry names the text of model/blocked_c.py and model/blocked.py (the
    key's parts recorded; nothing compiled)."""
    seen = []
    monkeypatch.setattr(compiled, "entry_key", lambda kind, graph, extra=None: seen.append((kind, extra)))
    s, p = ca.SX.sym("s"), ca.SX.sym("p", 2)
    blocked.stroke_evaluator(ca.Function("g", [s, p], [p[0] * ca.sin(s) + p[1]], ["s", "p"], ["v"]))
    assert seen and seen[0][0] == "external"
    assert seen[0][1]["writer"] == compiled.code_hash((blocked_c.__file__, blocked.__file__))
