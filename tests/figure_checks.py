"""Checks of what a figure file holds (shared by the figure tests): a PNG or GIF of a sensible
size that is not blank, an SVG with drawn paths."""
from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np


def check_png(path, min_size=(300, 200), min_ink=0.01, min_colours=8):
    """The image at ``path`` is at least ``min_size`` pixels and not blank: at least
    ``min_ink`` of its pixels differ from the background and it has ``min_colours`` colours."""
    from PIL import Image

    path = Path(path)
    assert path.is_file() and path.stat().st_size > 2000, f"{path}: missing or tiny"
    with Image.open(path) as im:
        assert im.width >= min_size[0] and im.height >= min_size[1], f"{path}: {im.size} is too small"
        rgb = np.asarray(im.convert("RGB"), dtype=int)
    return _ink(rgb, path, min_ink, min_colours)


def _ink(rgb, path, min_ink, min_colours):
    background = np.median(rgb.reshape(-1, 3), axis=0)
    ink = np.mean(np.abs(rgb - background).sum(axis=2) > 30)
    colours = len(np.unique(rgb.reshape(-1, 3)[:: max(1, rgb.size // 3 // 200000)], axis=0))
    assert ink >= min_ink, f"{path}: only {ink:.2%} of the pixels are drawn (blank?)"
    assert colours >= min_colours, f"{path}: only {colours} colours"
    return ink


def gif_frames(path):
    """The frames of a GIF as RGB arrays."""
    from PIL import Image, ImageSequence

    with Image.open(path) as im:
        return [np.asarray(f.convert("RGB"), dtype=int) for f in ImageSequence.Iterator(im)]


def check_svg(path, min_paths=20):
    """An SVG document with at least ``min_paths`` drawn paths; returns its root element."""
    root = ET.parse(path).getroot()
    assert root.tag.endswith("svg"), f"{path}: not an SVG document"
    paths = [e for e in root.iter() if e.tag.endswith("path")]
    assert len(paths) >= min_paths, f"{path}: only {len(paths)} paths"
    return root
