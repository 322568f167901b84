"""`optdesign animate` (issue 17, piece 3): the mechanism moving over its stroke as a GIF (frames
counted, the mechanism seen moving) and, where ffmpeg is on PATH, an MP4; the drive force traced
beside it and the transmission angle: the scene's own constraint where it has one, else the
angle between the actuator and its pins' relative motion (checked against the jib's angle
(D, B, A) computed here)."""
from __future__ import annotations

import dataclasses
import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

import optdesign
from optdesign.cli import main as cli
from optdesign.report.animate import animate, transmission
from optdesign.report.geometry import Geometry

from figure_checks import _ink, gif_frames

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"
TRUCK = PROBLEMS / "truck_crane.toml"


def test_gif_frames_move(tmp_path):
    scene = optdesign.load(TRUCK)
    (gif,) = animate(scene, [tmp_path / "a.gif"], frames=6)
    frames = gif_frames(gif)
    assert len(frames) == 6
    h, w = frames[0].shape[:2]
    assert w >= 600 and h >= 300
    for f in (frames[0], frames[-1]):
        _ink(f, gif, 0.03, 8)
    # the boom turns by 80 deg over the stroke: the left half (the mechanism) changes a lot
    left = slice(0, w // 2)
    changed = np.mean(np.abs(frames[0][:, left] - frames[-1][:, left]).sum(axis=2) > 60)
    assert changed > 0.01
    # consecutive frames differ too (a moving marker on the traces at least)
    assert all(np.any(a != b) for a, b in zip(frames[:-1], frames[1:]))


def test_transmission_angle_is_the_scenes_constraint_or_the_actuators():
    scene = optdesign.load(TRUCK)
    analysis = optdesign.analyse(scene)
    geometry = Geometry(scene)
    s = geometry.stroke(9)
    label, values, unit, bounds = transmission(scene, geometry, analysis, s)
    assert label == "transmission angle" and unit == "deg"
    np.testing.assert_allclose(bounds, (25.0, 155.0))
    # the angle at B between B->D and B->A, computed here from the points
    frames = geometry.frames(s)
    A, B, D = (frames.points[n] for n in "ABD")
    u, v = D - B, A - B
    angle = np.degrees(np.arccos(np.einsum("ij,ij->i", u, v) / np.hypot(*u.T) / np.hypot(*v.T)))
    np.testing.assert_allclose(values, angle, atol=1e-6)
    # without the constraint: 90 deg minus the angle between the cylinder and the rod eye's
    # velocity, which is square to A->B; so 90 - |90 - angle(D, B, A)|
    bare = dataclasses.replace(scene, constraints=(), objective=None)
    label, generic, unit, bounds = transmission(bare, Geometry(bare), None, s)
    assert unit == "deg" and bounds is None and "actuator" in label
    np.testing.assert_allclose(generic, 90 - np.abs(90 - angle), atol=1e-8)


def test_scene_without_a_drive(tmp_path):
    scene = optdesign.load(PROBLEMS / "seed2_fourbar.toml")
    (gif,) = animate(scene, [tmp_path / "f.gif"], frames=4)
    assert len(gif_frames(gif)) == 4


def test_command(tmp_path, capsys):
    out = tmp_path / "anim.gif"
    result = tmp_path / "result.json"
    result.write_text(json.dumps({"design": {"xD": 0.2575, "yD": -1.8, "b": 1.031}}))
    assert cli.main(["animate", str(TRUCK), "--out", str(out), "--frames", "5", "--no-mp4",
                     "--design", str(result)]) == 0
    assert len(gif_frames(out)) == 5
    assert not out.with_suffix(".mp4").exists()
    assert "5 frames over the stroke" in capsys.readouterr().out
    assert cli.main(["animate", str(TRUCK), "--out", str(tmp_path / "anim.png")]) == 2
    assert "expected a file name ending in .gif" in capsys.readouterr().err


def test_default_file(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["animate", str(TRUCK), "--frames", "3", "--no-mp4"]) == 0
    assert len(gif_frames(tmp_path / "optdesign-results" / "truck_crane-animation.gif")) == 3


@pytest.mark.skipif(shutil.which("ffmpeg") is None, reason="ffmpeg is not on PATH (CI installs it in .ci/run)")
def test_mp4_where_ffmpeg_is_available(tmp_path):
    out = tmp_path / "anim.gif"
    assert cli.main(["animate", str(TRUCK), "--out", str(out), "--frames", "7"]) == 0
    mp4 = out.with_suffix(".mp4")
    assert mp4.read_bytes()[4:8] == b"ftyp"
    if shutil.which("ffprobe"):
        probe = subprocess.run(["ffprobe", "-v", "error", "-count_frames", "-select_streams", "v:0", "-show_entries",
                                "stream=nb_read_frames,codec_name", "-of", "json", str(mp4)],
                               capture_output=True, text=True, check=True)
        stream = json.loads(probe.stdout)["streams"][0]
        assert stream["codec_name"] == "h264" and int(stream["nb_read_frames"]) == 7


def test_pin_forces_drawn_in_the_governing_case(tmp_path):
    """The animation draws the pin forces (issue 30) of the case with the largest pin force:
    the jib with a 'rated' and a 'test load' case (mC 500 and 625 kg) draws those of 'test
    load', the forces analyse gives that case at its samples, and names it in a note; a still
    shows arrows in the pins' colour, a scene without a drive none."""
    import sys

    from optdesign.report.joint_arrows import PIN, governing_pin_forces

    sys.path.insert(0, str(Path(__file__).parent))
    from test_joint_forces import CASES

    scene = optdesign.loads(CASES)
    an = optdesign.analyse(scene, samples=21, joints=True, certify=False)
    case = an.cases.cases["test load"]
    forces, name = governing_pin_forces(scene, case.columns["s"])
    assert name == "test load" and set(forces) == {"A", "B", "D"}
    for p, f in forces.items():
        assert an.cases.governing[f"pin_force({p})"]["case"] == "test load"
        np.testing.assert_allclose(f[0], case.columns[f"pin_force_x({p})"], rtol=1e-12, atol=1e-9)
        np.testing.assert_allclose(f[1], case.columns[f"pin_force_y({p})"], rtol=1e-12, atol=1e-9)
    pin = np.array([int(PIN[i:i + 2], 16) for i in (1, 3, 5)])

    def purple(path):
        from PIL import Image

        rgb = np.asarray(Image.open(path).convert("RGB"), int)
        return int(np.sum(np.abs(rgb - pin).sum(axis=2) < 40))

    (still,) = animate(scene, [tmp_path / "jib.png"], at=[0.5])
    (bare,) = animate(optdesign.load(PROBLEMS / "seed2_fourbar.toml"), [tmp_path / "fourbar.png"], at=[0.5])
    assert purple(still) > 100 and purple(bare) == 0
