"""``results/bench.md`` holds one section per benchmark script; each script rewrites only its own
section (between ``<!-- begin NAME -->`` and ``<!-- end NAME -->``) and leaves the others as
they were, atomically (the file is never half-written)."""
from __future__ import annotations

import re
from pathlib import Path

from optdesign.report import write_atomic

ROOT = Path(__file__).resolve().parents[1]
BENCH_MD = ROOT / "results" / "bench.md"
ORDER = ("reduced_model", "optimise", "study")   # the order of the sections in the file
TITLE = "# Benchmarks\n\nEach section is written by the script it names, in one run of that script; ratios are measured within one run.\n"


def write_section(name: str, markdown: str, path: Path = BENCH_MD) -> Path:
    """Replace (or add) section ``name`` of ``path`` with ``markdown`` (its headings one level
    down, under the file's title)."""
    path = Path(path)
    markdown = re.sub(r"^#", "##", markdown, flags=re.M)
    text = path.read_text() if path.exists() else ""
    sections = {m.group(1): m.group(0) for m in
                re.finditer(r"<!-- begin (\w+) -->\n.*?<!-- end \1 -->\n", text, flags=re.S)}
    sections[name] = f"<!-- begin {name} -->\n{markdown.rstrip()}\n<!-- end {name} -->\n"
    names = [n for n in ORDER if n in sections] + sorted(n for n in sections if n not in ORDER)
    write_atomic(path, TITLE + "\n" + "\n".join(sections[n] for n in names))
    return path
