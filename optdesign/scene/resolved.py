"""The scene resolved once, on its way into the pipeline: parameters to numbers or CasADi symbols.

A :class:`~optdesign.scene.scene.Scene` holds expressions.  The pipeline below it (kinematics,
model, dynamics, design, report) needs numbers (the parameters' values, the stroke, bounds) and
CasADi graphs (the parameters as symbols, derived parameters as expressions of them).  It gets
both from one :class:`ResolvedScene`, made once where a scene enters the pipeline and handed
down, instead of evaluating the scene's expressions again wherever a value is used.
"""
from __future__ import annotations

import numpy as np

from .expressions import Expression, constant_value, evaluate


class ResolvedScene:
    """A validated scene with its parameters and stroke evaluated.

    Attributes:
        scene:        the :class:`~optdesign.scene.scene.Scene` (its items: points, bodies,
                      drive, constraints, simulation).
        values:       every parameter's number (name -> float), derived ones evaluated in order.
        leaf_names:   the parameters given as numbers, in file order (design variables among
                      them): the entries of the parameter vector p of every CasADi graph.
        leaf_values:  their numbers (a float array, p at the scene's values).
        derived:      the parameters defined by expressions of earlier ones (``Parameter``\\ s).
        design_names: the design variables (parameters with min/max), in file order.
        variable:     other parameters whose value changes between runs of one build (a
                      study's axes): :meth:`fixed_value` folds none of them, nor a design variable.
        axes:         of them the study's axes alone (``variable`` as given, without the
                      parameters the load cases override).
        sweep_name, start, stop, samples: the stroke ([sweep] name, from, to as numbers, samples).
    """

    def __init__(self, scene, variable=()):
        self.scene = scene
        self.values = scene.parameter_values()
        self.leaf_names = tuple(p.name for p in scene.parameters if not p.value.names())
        self.leaf_values = np.array([self.values[n] for n in self.leaf_names], dtype=float)
        self.derived = tuple(p for p in scene.parameters if p.value.names())
        self.design_names = tuple(p.name for p in scene.parameters if p.is_design)
        # parameters whose value changes between runs of one build (a study's axes): like the
        # design variables, never folded into a constant by fixed_value
        # and the parameters a load case overrides (its `set`): one graph serves every case, so
        # a payload or a wind force that is 0 in the scene must not be folded away as absent
        overridden = [n for c in getattr(scene, "cases", ()) for n in c.overrides]
        self.variable = tuple(dict.fromkeys((*variable, *overridden)))
        self.axes = tuple(dict.fromkeys(variable))   # (the study's axes alone)
        self._uses = {p.name: p.value.names() for p in scene.parameters}
        sweep = scene.sweep
        self.sweep_name = sweep.name
        self.start = self.constant(sweep.start, "[sweep] from")
        self.stop = self.constant(sweep.stop, "[sweep] to")
        self.samples = sweep.samples

    def __repr__(self):
        return f"ResolvedScene({self.scene.path!r}, p = {dict(zip(self.leaf_names, self.leaf_values))})"

    # --- numbers ---
    def constant(self, expr: Expression, where) -> float:
        """``expr`` (numbers, parameters, pi, deg) as a finite number at the scene's values;
        raises :class:`~optdesign.errors.ExpressionError` naming ``where`` otherwise."""
        return constant_value(expr, self.values, where)

    def fixed_value(self, expr: Expression) -> float | None:
        """The number of ``expr`` when it is the same for every design and every sample (no
        points, no sweep variable, no design variable, directly or through derived
        parameters); else None."""
        if expr.points() or self.sweep_name in expr.names():
            return None
        if self.depends_on(expr, self.design_names + self.variable):
            return None
        return self.constant(expr, "")

    def depends_on(self, expr: Expression, names) -> bool:
        """True when ``expr`` uses any of ``names`` directly or through derived parameters."""
        seen, todo = set(), set(expr.names())
        while todo:
            n = todo.pop()
            if n in names:
                return True
            if n in self._uses and n not in seen:
                seen.add(n)
                todo |= self._uses[n]
        return False

    def stroke(self, samples: int | None = None) -> np.ndarray:
        """The sweep values from ``start`` to ``stop``: the scene's samples, or ``samples`` (a
        whole number >= 2 that fits in memory: :func:`~optdesign.scene.arguments.stroke_samples`)."""
        from .arguments import stroke_samples

        n = stroke_samples(self.scene, self.samples if samples is None else samples)
        return np.linspace(self.start, self.stop, n)

    # --- symbols ---
    def environment(self, p) -> dict:
        """Every parameter as a value of the leaf vector ``p`` (CasADi symbols or numbers, one
        entry per ``leaf_names``): leaf i -> p[i], a derived parameter -> its expression
        evaluated on those."""
        env = {n: p[i] for i, n in enumerate(self.leaf_names)}
        for prm in self.derived:
            env[prm.name] = evaluate(prm.value, env, {}, f"[parameters] {prm.name}")
        return env

    def symbols(self, sym) -> tuple:
        """A new parameter vector ``p = sym.sym("p", len(leaf_names))`` (``sym`` is ca.SX or
        ca.MX) and :meth:`environment` of it."""
        p = sym.sym("p", len(self.leaf_names))
        return p, self.environment(p)
