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
