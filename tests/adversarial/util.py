"""Shared by the adversarial suite: paths, a CLI runner, folder snapshots."""
from __future__ import annotations

import hashlib
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PROBLEMS = ROOT / "problems"
JIB = PROBLEMS / "seed1_jib.toml"
JIB_DESIGN = PROBLEMS / "seed1_jib_design.toml"
SIM = PROBLEMS / "sim_slider_crank.toml"
ROOT_USER = hasattr(os, "geteuid") and os.geteuid() == 0


def cli(*args, cwd=None, timeout=120, **kw):
    """``optdesign ARGS`` in a subprocess: (returncode, stdout, stderr)."""
    done = subprocess.run([sys.executable, "-m", "optdesign", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd or ROOT, timeout=timeout, env={**os.environ, "MPLBACKEND": "Agg"}, **kw)
    return done.returncode, done.stdout, done.stderr


def snapshot(folder) -> dict:
    """name -> sha256 of every file in ``folder`` (recursively), None if it does not exist."""
    folder = Path(folder)
    if not folder.exists():
        return None
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}
