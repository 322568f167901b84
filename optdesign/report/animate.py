"""The mechanism moving over its stroke: a GIF (Pillow, as matplotlib's PillowWriter) and, where
ffmpeg is on PATH, an MP4, with the drive force or torque traced beside it and the transmission angle.

The transmission angle is the scene's own where it has a per-sample constraint named
'transmission ...' (in its units, with its bounds); otherwise, for a linear drive, the angle
mu = 90 deg - alpha, where alpha is the angle between the actuator's axis and the relative
velocity of its two pins (CasADi's derivative in s): mu = 90 deg when the whole motion of the
pins goes into the actuator's length, 0 at a dead centre."""
from __future__ import annotations

import io
import os
import shutil
import textwrap
from pathlib import Path

import numpy as np

from .drawing import context, draw_mechanism, draw_paths, frame_view, limits
from .files import place, temporary_for, write_file
from .geometry import Geometry
from .joint_arrows import PIN, arrow_scale, draw_pin_arrows, governing_pin_forces
from .layout import animation_layout
from .topology import topology
from .plots import bound_lines, headroom, mark_peak
from .sprites import TextSprites
from .units import constraint_scale, scaled, sweep_scale

DRIVE_UNIT = {"rotary": ("drive torque", "N m"), "linear": ("drive force", "N")}



def caption_value(value: float, peak: float) -> float:
    """A value for the frame's caption: round-off at a zero of the load (the compressor's crank at
    a dead centre read -1.942e-13 N m against a 104.6 N m peak) is shown as 0."""
    return 0.0 if abs(value) <= 1e-9 * peak else float(value)

def drive_curve(scene, analysis) -> tuple:
    """(label, s ascending, values, SI unit) of the side panel's load: with load cases the
    governing case's motor torque (with a motor) or drive load, named so; else the nominal
    [drive] state's drive load."""
    name, base = DRIVE_UNIT[scene.drive.kind]
    cases = getattr(analysis, "cases", None)
    if cases is not None:
        key = "motor_torque" if any("motor_torque" in c.columns for c in cases.cases.values()) else "drive"
        g = cases.governing.get(key)
        if g is not None:
            c = cases.cases[g["case"]]
            order = np.argsort(c.columns["s"], kind="stable")
            label = "motor torque" if key == "motor_torque" else name
            return (f"{label}, case '{g['case']}' (governing)", np.asarray(c.columns["s"], float)[order],
                    np.asarray(c.columns[key], float)[order], "N m" if key == "motor_torque" else base)
    return name, np.asarray(analysis.columns["s"], float), np.asarray(analysis.columns["drive"], float), base


def transmission(scene, geometry, analysis, s):
    """(label, values at ``s``, unit, (lower, upper) or None) of the transmission angle, or
    None where there is none to show."""
    for c in scene.constraints:
        if "transmission" in c.name.lower() and analysis is not None and np.ndim(analysis.constraints.get(c.name)):
            factor, unit = constraint_scale(c)
            values = np.interp(s, analysis.columns["s"], analysis.constraints[c.name]) * factor
            bounds = tuple(None if b is None else geometry.resolved.constant(b, c.name) * factor
                           for b in (c.lower, c.upper))
            return c.name, values, unit, bounds
    if scene.drive is None or scene.drive.kind != "linear":
        return None
    import casadi as ca

    mech = geometry.mech
    p, q = (mech.points[n] for n in scene.drive.pins)
    d = q - p
    w = mech.ds(d)
    cos_alpha = ca.fabs(ca.dot(d, w)) / (ca.norm_2(d) * ca.norm_2(w))
    f = mech.function("transmission", {"cos": cos_alpha}).map(len(s))
    with np.errstate(invalid="ignore"):
        c = np.clip(np.asarray(f(s=np.asarray(s)[None, :], p=mech.parameter_values)["cos"], float).ravel(), 0, 1)
    return "transmission angle (actuator to its pins' motion)", 90.0 - np.degrees(np.arccos(c)), "deg", None


def animate(scene, paths, frames=36, fps=12, dpi=80, title=None, analysis=None, at=None, label="") -> list:
    """Write the animation of ``scene`` to every path in ``paths`` (.gif always; .mp4 only where
    ffmpeg is available: others are skipped; .png: the first frame alone); returns the paths
    written.  ``at``: fractions of the stroke (0 its start, 1 its end) to draw instead of
    ``frames`` evenly spread ones (a still: ``at=[0.6]`` with a .png path).  ``analysis``: an
    :class:`~optdesign.model.analysis.AnalysisResult` of the same scene (made here if None and
    the scene has a drive).  Each file is written by report/files.py (``label``: the option that
    named the paths; ``-``: a GIF on standard output)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from ..scene.arguments import animation_frames

    frames = animation_frames(frames, dpi) if at is None else frames
    geometry = Geometry(scene)
    scene = geometry.scene
    top = topology(scene)
    dense = geometry.frames(geometry.stroke(max(frames, 61)))
    ctx = context(top, dense)
    s = geometry.stroke(frames) if at is None else geometry.resolved.start + np.asarray(at, float) * (
        geometry.resolved.stop - geometry.resolved.start)
    shots = geometry.frames(s)
    # the pin forces of every frame (the governing case's with [[cases]]), on one scale: their
    # largest over the stroke a fifth of the mechanism (report/joint_arrows.py)
    pins, pin_case = governing_pin_forces(scene, np.r_[s, dense.s])
    pin_scale = arrow_scale(pins, ctx.extent)
    for p, f in pins.items():
        ctx.extra += [shots.at(i).points[p][0] + f[:, i] * pin_scale for i in range(len(s))]
    if analysis is None and scene.drive is not None:
        from ..model.analysis import analyse

        analysis = analyse(scene)
    factor, unit = sweep_scale(scene)
    trans = transmission(scene, geometry, analysis, s)
    curve_s = analysis.columns["s"] if analysis is not None else geometry.stroke(121)
    curve = transmission(scene, geometry, analysis, curve_s) if trans is not None else None
    box = limits([ctx])
    aspect = (box[3] - box[2]) / max(box[1] - box[0], 1e-12)
    side = analysis is not None or trans is not None
    fig = Figure(figsize=(10.5 if side else 6.5, float(np.clip(5.2 * aspect, 4.2, 7.0))), dpi=dpi)
    FigureCanvasAgg(fig)
    mech_ax = fig.add_axes([0, 0, 1, 1])      # placed by animation_layout below
    markers = []
    if analysis is not None:
        ax = fig.add_axes([0, 0, 1, 1])
        name, drive_s, drive, base = drive_curve(scene, analysis)
        k, shown = scaled(drive, base)
        x = drive_s * factor
        ax.plot(x, drive * k, color="#1f77b4", lw=1.6)
        i = int(np.argmax(np.abs(drive)))
        mark_peak(ax, x[i], drive[i] * k, f"peak {abs(drive[i]) * k:.4g} {shown}")
        headroom(ax)
        ax.set_ylabel(textwrap.fill(f"{name} [{shown}]", 40), fontsize=8)
        ax.grid(alpha=0.3)
        ax.tick_params(labelsize=7)
        values = np.interp(s, drive_s, drive) * k
        peak = abs(drive[i]) * k   # over the stroke, not the frames drawn (a still has one)
        (dot,) = ax.plot([], [], "o", color="black", ms=6)
        line = ax.axvline(x[0], color="black", lw=0.8, alpha=0.6)
        markers.append((dot, line, values))
    if trans is not None:
        ax = fig.add_axes([0, 0, 1, 1])
        trans_name, values, tunit, bounds = trans
        ax.plot(curve_s * factor, curve[1], color="#2ca02c", lw=1.6)
        if bounds:
            bound_lines(ax, *bounds)
        ax.set_ylabel(textwrap.fill(f"{trans_name} [{tunit}]", 32), fontsize=8)
        ax.grid(alpha=0.3)
        ax.tick_params(labelsize=7)
        (dot,) = ax.plot([], [], "o", color="black", ms=6)
        line = ax.axvline(s[0] * factor, color="black", lw=0.8, alpha=0.6)
        markers.append((dot, line, values))
    for ax in fig.axes[1:]:
        ax.set_xlabel(f"{scene.sweep.name} [{unit}]" if unit else scene.sweep.name, fontsize=8)
    head = textwrap.fill(title or scene.title, 90)
    fig.suptitle(head, fontsize=9.5, y=1 - 4 / 72 / fig.get_size_inches()[1], va="top")
    draw_paths(mech_ax, top, ctx)
    frame_view(mech_ax, [ctx], box=box)
    mech_ax.set_title(" ", fontsize=8.5)
    caption = mech_ax.text(0.5, 1.01, "", transform=mech_ax.transAxes, ha="center", va="bottom", fontsize=8.5,
                           animated=True)
    for dot, line, _ in markers:
        dot.set_animated(True)
        line.set_animated(True)
    # what never moves (ground, fixed guides) is part of the background, drawn once
    draw_mechanism(mech_ax, top, shots.at(0), ctx, labels=None, loads=False, masses=False, scene=scene,
                   parts="static")
    if pin_case is not None:   # (report/joint_arrows.py: the case with the largest pin force)
        mech_ax.text(0.01, 0.01, f"pin forces: case '{pin_case}' (the largest pin force)", transform=mech_ax.transAxes,
                     fontsize=6.5, color=PIN, ha="left", va="bottom", zorder=9)
    canvas = fig.canvas
    animation_layout(fig, mech_ax, fig.axes[1:], head.count("\n") + 1)
    canvas.draw()                       # every static artist, once
    background = canvas.copy_from_bbox(fig.bbox)
    # the view is fixed: the moving artists added per frame need not grow the data limits
    mech_ax._update_patch_limits = mech_ax._update_line_limits = lambda artist: None
    texts = TextSprites(canvas)   # the texts that come back in every frame are copied, not laid out again

    def render(i):
        canvas.restore_region(background)
        before = set(mech_ax.get_children())
        draw_mechanism(mech_ax, top, shots.at(i), ctx, labels="joints", loads=True, scene=scene, parts="moving")
        if pin_scale is not None and shots.assembled[i]:
            draw_pin_arrows(mech_ax, shots.at(i), {p: f[:, i] for p, f in pins.items()}, pin_scale, ctx.w)
        new = sorted((a for a in mech_ax.get_children() if a not in before), key=lambda a: a.get_zorder())
        for a in new:
            texts.draw(a)
        text = f"{scene.sweep.name} = {s[i] * factor:.4g} {unit}".rstrip()
        for dot, line, values in markers:
            dot.set_data([s[i] * factor], [values[i]])
            line.set_xdata([s[i] * factor, s[i] * factor])
            dot.axes.draw_artist(line)
            dot.axes.draw_artist(dot)
        if analysis is not None:
            text += f"   {name.split(',')[0]} {caption_value(markers[0][2][i], peak):.4g} {shown}"
        if trans is not None:
            text += f"   transmission {trans[1][i]:.3g} {trans[2]}"
        if not shots.assembled[i]:
            text += f"   (does not assemble: [points] {shots.failed[i]})"
        caption.set_text(text)
        texts.draw_line(caption)     # its words and units from sprites, its numbers drawn
        image = np.asarray(canvas.buffer_rgba()).copy()
        for a in new:
            a.remove()
        return image

    paths = [p if str(p) == "-" else Path(p) for p in paths]
    mp4 = [p for p in paths if Path(p).suffix.lower() == ".mp4"] if ffmpeg_available() else []
    w, h = canvas.get_width_height(physical=True)
    # the MP4 is encoded by ffmpeg while the frames are drawn, from the same frames as the GIF
    streams = [Mp4Stream(p, w, h, fps, label) for p in mp4]
    try:
        images = []
        for i in range(len(s)):
            images.append(render(i))
            for stream in streams:
                stream.add(images[-1])
        written = []
        for path in paths:
            suffix = Path(path).suffix.lower()
            if suffix == ".png":
                from PIL import Image

                written.append(write_file(path, _encoded(lambda fh: Image.fromarray(
                    np.ascontiguousarray(images[0][..., :3])).save(fh, format="PNG")), label))
            elif suffix == ".mp4":
                if path in mp4:
                    written.append(streams[mp4.index(path)].finish())
            else:
                written.append(write_file(path, _encoded(lambda fh: write_gif(images, fh, fps)), label))
    finally:
        for stream in streams:
            stream.abandon()
    return written


def _encoded(write) -> bytes:
    """The bytes that ``write(file)`` writes (a GIF or PNG made in memory, then written by
    report/files.py: a FIFO or standard output cannot be sought in as Pillow may)."""
    buf = io.BytesIO()
    write(buf)
    return buf.getvalue()


def write_gif(images, path, fps):
    """RGBA frames as a looping GIF, written with Pillow (as matplotlib's PillowWriter does), all
    frames on one palette made from a few of them (10x faster than a palette per frame)."""
    from PIL import Image

    h, w = images[0].shape[:2]
    frames = [Image.frombuffer("RGBA", (w, h), np.ascontiguousarray(im), "raw", "RGBA", 0, 1).convert("RGB")
              for im in images]
    picks = frames[::max(1, len(frames) // 4)][:4]
    mosaic = Image.new("RGB", (w, h * len(picks)))
    for k, f in enumerate(picks):
        mosaic.paste(f, (0, h * k))
    palette = mosaic.quantize(colors=255, method=Image.Quantize.FASTOCTREE)
    frames = [f.quantize(palette=palette, dither=Image.Dither.NONE) for f in frames]
    frames[0].save(path, format="GIF", save_all=True, append_images=frames[1:], duration=int(1000 / fps), loop=0)


FFMPEG_H264 = ("-vcodec", "libx264", "-preset", "veryfast", "-threads", "1", "-pix_fmt", "yuv420p")


def _ffmpeg_command(w, h, fps, path):
    """ffmpeg reading RGBA frames of w x h from its stdin (as matplotlib's FFMpegWriter pipes
    them) and writing an H.264 MP4 at ``path`` (at the default quality, CRF 23; the 'veryfast'
    preset on one thread: a third of the CPU of the default preset for a 5 % larger file)."""
    return ["ffmpeg", "-y", "-loglevel", "error", "-f", "rawvideo", "-vcodec", "rawvideo", "-s", f"{w}x{h}",
            "-pix_fmt", "rgba", "-framerate", str(fps), "-i", "pipe:", "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2",
            *FFMPEG_H264, "-f", "mp4", str(path)]


class Mp4Stream:
    """An MP4 written by ffmpeg as its frames come (:meth:`add`), into a temporary file that
    :meth:`finish` puts at ``path`` (report/files.place: renamed onto a regular file, copied
    into a FIFO or device); a feeding thread keeps the drawing of
    the next frame from waiting on the pipe.  :meth:`abandon` stops it and removes the
    temporary file (after :meth:`finish`: nothing to do)."""

    def __init__(self, path, w, h, fps, label=""):
        import queue
        import subprocess
        import threading

        self.path, self.label = Path(path), label
        self.tmp = temporary_for(self.path, label, suffix=".mp4")
        self.proc = subprocess.Popen(_ffmpeg_command(w, h, fps, self.tmp), stdin=subprocess.PIPE,
                                     stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        self.frames = queue.Queue()
        self.error = None
        self.thread = threading.Thread(target=self._feed, daemon=True)
        self.thread.start()

    def _feed(self):
        while (frame := self.frames.get()) is not None:
            if self.error is None:
                try:
                    self.proc.stdin.write(frame)
                except OSError as exc:   # ffmpeg ended early: its message says why (finish)
                    self.error = exc
        try:
            self.proc.stdin.close()
        except OSError:
            pass

    def add(self, image):
        """Queue a frame (an RGBA array that is not changed afterwards: written as it is)."""
        self.frames.put(memoryview(np.ascontiguousarray(image)).cast("B"))

    def finish(self):
        self.frames.put(None)
        self.thread.join()
        err = self.proc.stderr.read()
        if self.proc.wait() or self.error is not None:
            from ..errors import OptdesignError

            raise OptdesignError(f"ffmpeg could not write {self.path}: "
                                 f"{err.decode(errors='replace').strip() or self.error}")
        return place(self.tmp, self.path, self.label)

    def abandon(self):
        if self.thread.is_alive():
            self.frames.put(None)
            self.proc.kill()
            self.thread.join()
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait()
        self.proc.stderr.close()
        if os.path.exists(self.tmp):
            os.unlink(self.tmp)


def write_mp4(images, path, fps):
    """RGBA frames as an H.264 MP4 through ffmpeg (:class:`Mp4Stream`)."""
    h, w = images[0].shape[:2]
    stream = Mp4Stream(path, w, h, fps)
    try:
        for image in images:
            stream.add(image)
        stream.finish()
    finally:
        stream.abandon()


def ffmpeg_available() -> bool:
    return shutil.which("ffmpeg") is not None
