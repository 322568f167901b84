"""matplotlib imported for drawing at less CPU: :func:`import_for_drawing` imports its figure and
its Agg and SVG canvases without building the property tables of its artists' docstrings.

Each Artist class that matplotlib defines gets a ``set()`` whose docstring lists every property
(``matplotlib.artist.kwdoc``: every setter inspected, its docstring cleaned and parsed), and
some docstrings are filled with those lists: about a quarter of the import's CPU (0.25 of 0.98 s,
measured), for text that no figure reads.  While the import runs, ``kwdoc`` gives an empty text;
it is put back afterwards (an artist class defined later gets its full docstring).  Nothing a
figure draws comes from a docstring: the files are the same bytes.  Where matplotlib is imported
already (a notebook, a test), or has no ``kwdoc``, it is imported as it is."""
from __future__ import annotations

import sys


def import_for_drawing():
    """Import matplotlib's Figure and its Agg and SVG canvases (see the module's text)."""
    if "matplotlib.figure" not in sys.modules:
        import matplotlib.artist as artist

        kwdoc = getattr(artist, "kwdoc", None)
        if kwdoc is not None:
            artist.kwdoc = _no_properties
        try:
            _import()
        finally:
            if kwdoc is not None:
                artist.kwdoc = kwdoc
    _import()


def _no_properties(artist) -> str:
    return ""


def _import():
    import matplotlib.backends.backend_agg  # noqa: F401
    import matplotlib.backends.backend_svg  # noqa: F401
    import matplotlib.figure  # noqa: F401
