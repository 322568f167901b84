"""Data loss, standard output: a report of many samples is written in rows (never one giant
write that the kernel cuts at 2 GB), the same bytes as the one-piece text, with its summary at
the end; a full disk or a closed pipe is a clear outcome, not a traceback."""
from __future__ import annotations

import io
import json
import subprocess
import sys

import pytest

import optdesign
from optdesign.cli.main import main
from optdesign.report.analysis import analysis_json, analysis_table, kinematics_json, kinematics_table
from optdesign.report.output import Rows, _clean, json_chunks, table, table_chunks, to_json
from optdesign.report.simulation import simulation_json, summary

from .util import JIB, ROOT, SIM, cli


class Recorder(io.StringIO):
    """Standard output that remembers the size of every write."""

    def __init__(self):
        super().__init__()
        self.sizes = []

    def write(self, text):
        self.sizes.append(len(text))
        return super().write(text)


@pytest.fixture(scope="module")
def big_analysis():
    return optdesign.analyse(optdesign.load(JIB), 20_000)


@pytest.mark.parametrize("json_flag", [False, True])
def test_analyse_streams_many_rows_in_small_writes_with_the_same_bytes(monkeypatch, big_analysis, json_flag):
    from optdesign.model import analysis as model_analysis

    monkeypatch.setattr(model_analysis, "analyse", lambda scene, samples, **options: big_analysis)
    out = Recorder()
    monkeypatch.setattr(sys, "stdout", out)
    assert main(["analyse", str(JIB), "--samples", "20000", "--table"] + (["--json"] if json_flag else [])) == 0
    text = out.getvalue()
    assert len(out.sizes) > 10 and max(out.sizes) < 1_000_000          # rows in pieces, not one write
    if json_flag:
        doc = analysis_json(big_analysis)
        assert text == json.dumps(_clean({**doc, "samples": list(doc["samples"])}), indent=1, allow_nan=False) + "\n"
        assert len(json.loads(text)["samples"]) == 20_000
    else:
        from optdesign.report.checks import summary_lines

        # --table keeps the summary: the rows and their peaks, then the summary in the scene's units
        assert text == analysis_table(big_analysis) + "\n\n" + "\n".join(summary_lines(big_analysis)) + "\n"
        assert text.splitlines()[20_002].startswith("peak |drive| = ")    # the summary after the rows


def test_the_json_of_a_report_is_made_row_by_row():
    made = []
    rows = Rows(5, lambda i: made.append(i) or {"i": i, "x": [float(i), float("nan")]})
    pieces = json_chunks({"a": {"b": 1}, "samples": rows, "z": []}, batch=2)
    head = next(pieces)
    assert head == "{" and made == []                 # nothing made before it is written
    text = head + "".join(pieces)
    assert made == [0, 1, 2, 3, 4]
    assert text == json.dumps({"a": {"b": 1}, "samples": [{"i": i, "x": [float(i), None]} for i in range(5)],
                               "z": []}, indent=1)
    assert to_json({}) == "{}" and to_json({"s": Rows(0, None)}) == '{\n "s": []\n}'
    assert rows[-1]["i"] == 4 and [r["i"] for r in rows[1:3]] == [1, 2]
    with pytest.raises(IndexError):
        rows[5]


def test_tables_in_pieces_are_the_table():
    cols = {"a": [1.0, 2.5, 3.0], "long_name_here": [4.0, 5.0, 6.0]}
    assert "".join(table_chunks(cols, batch=1)) == table(cols)
    assert table(cols).splitlines()[2].split() == ["2.5", "5"]


def test_kinematics_and_simulation_reports_keep_their_text(big_analysis):
    scene = optdesign.load(JIB)
    kin = optdesign.kinematics(scene, 50)
    doc = kinematics_json(kin)
    assert isinstance(doc["samples"], Rows) and len(doc["samples"]) == 50
    assert json.loads(to_json(doc))["samples"][49]["s"] == pytest.approx(kin.s[-1])
    assert kinematics_table(kin).count("\n") == 50
    sim = optdesign.simulate(optdesign.load(SIM))
    assert len(json.loads(to_json(simulation_json(sim)))["samples"]) == len(sim.t)
    assert summary(sim).splitlines()[len(sim.t) + 2] == sim.scene.title


def test_a_full_disk_on_standard_output_is_an_error_saying_the_output_is_incomplete():
    with open("/dev/full", "w") as full:
        done = subprocess.run([sys.executable, "-m", "optdesign", "analyse", str(JIB)], stdout=full,
                              stderr=subprocess.PIPE, text=True, cwd=ROOT, timeout=60)
    assert done.returncode == 2
    assert done.stderr.strip() == ("optdesign analyse: error: standard output: No space left on device: "
                                   "the output is incomplete")


def test_a_reader_that_stops_reading_ends_the_command_quietly():
    proc = subprocess.Popen([sys.executable, "-m", "optdesign", "analyse", str(JIB), "--samples", "200000", "--table"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=ROOT)
    first = proc.stdout.readline()
    proc.stdout.close()                                  # `| head -1`
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=60) == 141 and first.split()[0] == b"s"
    assert err == ""


def test_the_command_prints_the_peaks_after_the_rows():
    code, out, err = cli("analyse", JIB, "--samples", "3000", "--table")
    assert code == 0, err
    lines = out.splitlines()
    assert len(lines) > 3002 and lines[3002].startswith("peak |drive| = ")
