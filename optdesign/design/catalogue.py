"""A motor catalogue in the design problem (issue 16): the motors of [[motors]] in turn,
smallest rated torque first, the design optimised with each one's constraints (peak torque,
maximum speed, rated torque against the RMS over the duty cycle: :mod:`.cases`), until one
has a feasible optimum: the smallest motor that fits.  A motor is decided not to fit when phase
1 fails from every start's own point (the default 20): the starts are retried from fresh
points, as in a lone optimisation, only once one of them reaches a design feasible at the
sample points (:func:`.multistart.optimise`'s ``retry_if_fits``), so that a motor that fits
has the same result as without the rule, and one that cannot fit costs 20 phase-1 solves
instead of 100 (crane_luffing_drive's 4 and 5.5 kW motors: every one of their 100 phase-1
solves ended at the same least violation).  The larger motors are not optimised
(the question a catalogue answers is the smallest that fits; each motor is a whole multistart,
and crane_luffing_drive's 11 kW motor alone took 2-3 minutes of 20 starts).

A Ctrl-C keeps what finished: :func:`optimise_catalogue` raises
:class:`~optdesign.errors.OptimisationInterrupted` with the catalogue so far
(:func:`interrupted_catalogue`)."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from ..errors import OptimisationInterrupted, interrupt_pending, interruptible
from ..model.train import motor_numbers
from .multistart import optimise, prepare
from .proof_process import Proofs
from .results import OptimisationResult


RULE = ("failed from every start's own point (a motor of a catalogue: its starts are retried from fresh points "
        "only once one of them reaches a design feasible at the sample points)")


@dataclass(frozen=True)
class CatalogueResult:
    """Each motor's optimisation (``results``: name -> :class:`OptimisationResult`, in the order
    tried: by rated torque), the smallest that fits (``chosen``, or None) and its result
    (``best``: the chosen one's; without one, the last motor's, unsuccessful, or None when
    interrupted before any motor was decided); ``not_tried``:
    the larger motors left out once a smaller one fits (or, interrupted, not reached).

    Interrupted by Ctrl-C (:func:`interrupted_catalogue`): ``interrupted`` names the motor being
    optimised and ``interrupted_starts`` is (its starts finished, its starts planned; 0 planned
    when the Ctrl-C came before they were); ``results`` holds the motors decided before it and,
    when one of its finished starts found a feasible design, its result (marked interrupted:
    the best design of those starts).  That design proves the motor fits, so it is ``chosen``
    (all smaller motors were decided not to fit), though a better design of it may exist."""

    results: dict
    chosen: str | None
    best: OptimisationResult | None
    not_tried: tuple = ()
    interrupted: str | None = None
    interrupted_starts: tuple = ()
    motors: tuple = ()   # every motor of the catalogue, in the order tried (smallest rated torque first)
    proofs: dict = dataclasses.field(default_factory=dict)   # motor -> its EnergyProof (design/energy_bound.py)


def optimise_catalogue(scene, progress=None, **options) -> CatalogueResult:
    """Optimise ``scene`` once per motor of its catalogue, smallest first, until one fits
    (``options`` go to :func:`.multistart.optimise`); ``progress(label, done, total)`` per start
    of each motor, the label naming the motor and its place ("5.5 kW, motor 2 of 4").

    Ctrl-C raises :class:`~optdesign.errors.OptimisationInterrupted` (a KeyboardInterrupt) whose
    ``catalogue`` is the :class:`CatalogueResult` so far (the motors decided, the interrupted
    one with the best design of its finished starts, the motors not tried: see there; its
    ``best`` is None when nothing was decided: no motor finished and no start of the first
    found a feasible design); ``result``, ``finished`` and ``total`` are the interrupted
    motor's, as from :func:`.multistart.optimise`."""
    motors = motor_order(scene)
    results, chosen, ahead, proofs = {}, None, None, {}
    prover = Prover(scene, options.get("settings"))
    ready = {}   # motor index -> its Prepared, made here while a smaller motor's proof was sought (Proofs)
    # a Ctrl-C between two motors' starts (a motor's build, its proof) is kept too
    with interruptible(), Proofs(prover, motors, fork=options.get("workers", 1) > 1) as proving:
        for k, motor in enumerate(motors):
            one = with_motor(scene, motor)
            label = f"{motor.name}, motor {k + 1} of {len(motors)}"
            step = None if progress is None else (lambda done, total, label=label: progress(label, done, total))
            try:
                if ahead is None and len(proofs) == k:   # every smaller motor proved not to fit: try this one
                    proving.seek_from(k)
                    prepare_while_proved(proving, ready, motors, k, scene, options)
                    proof = proving.verdict(k)
                    if proof is not None:
                        proofs[motor.name] = proof
                        results[motor.name] = proved_result(one, proof, options.get("settings"))
                        ready.pop(k, None)
                        continue
                prepared, ahead = (ahead.result(), None) if ahead is not None else (ready.pop(k, None), None)
                following = with_motor(scene, motors[k + 1]) if k + 1 < len(motors) else None
                look_ahead = (Ahead(following, options) if following is not None and k + 1 not in ready
                              and options.get("workers", 1) > 1 else None)
                results[motor.name] = optimise(one, progress=step, prepared=prepared,
                                               finished=None if look_ahead is None else look_ahead.finished,
                                               planned=None if look_ahead is None else look_ahead.planned,
                                               retry_if_fits=True, **options)
                ahead = (look_ahead if look_ahead is not None and look_ahead.started else
                         Made(ready.pop(k + 1)) if k + 1 in ready else None)
            except KeyboardInterrupt as stop:
                raise interrupted_catalogue(motors, results, stop, proofs) from None
            except RuntimeError as exc:   # a Ctrl-C that CasADi reported as a failed call (errors.py)
                if not interrupt_pending() and "KeyboardInterrupt" not in str(exc):
                    raise
                raise interrupted_catalogue(motors, results, OptimisationInterrupted(), proofs) from None
            if results[motor.name].status == "infeasible":   # the rule of optimise's retry_if_fits, said
                results[motor.name] = dataclasses.replace(results[motor.name], message=results[motor.name].message.replace(
                    "failed from every start and its retries", RULE))
            if results[motor.name].success:
                chosen = motor.name
                break
    best = results[chosen] if chosen else results[motors[-1].name]
    return CatalogueResult(results, chosen, best, tuple(m.name for m in motors[len(results):]), motors=tuple(motors),
                           proofs=proofs)


class Prover:
    """The energy proof (:mod:`.energy_bound`) of the catalogue's scene, built on first use;
    ``prove(motor)`` gives the motor's proof or None (none found, or the scene is outside what
    the proof covers: ``why``)."""

    def __init__(self, scene, settings=None):
        self.scene, self.settings, self._bound, self.why, self._likely = scene, settings, None, None, {}

    def ready(self) -> bool:
        """The bound built (if it was not): whether a proof can be sought (else ``why`` says why not)."""
        from .energy_bound import EnergyBound, Unproven

        if self._bound is None and self.why is None:
            try:
                self._bound = EnergyBound(self.scene, self.settings)
            except Unproven as exc:
                self.why = str(exc)
        return self.why is None

    def prove(self, motor):
        return self._bound.prove(motor) if self.ready() else None

    def likely(self, motor) -> bool:
        """Whether ``motor``'s proof looks likely (:meth:`.energy_bound.EnergyBound.likely`): a
        guess of which motor to build while it is sought, never a verdict."""
        if motor.name not in self._likely:
            self._likely[motor.name] = self.ready() and self._bound.likely(motor)
        return self._likely[motor.name]


def prepare_while_proved(proving, ready, motors, k, scene, options):
    """While motor ``k``'s proof is sought in another process (:class:`.proof_process.Proofs`),
    the problem of the motor whose starts will likely run next built and its starts planned here
    (into ``ready``): the next motor's when this one's proof looks likely (crane_luffing_drive's
    4 kW motor), else this one's; nothing when either is made already.  The same problem and plan
    as made in turn; one made for a motor then proved is dropped, one for the motor after a motor
    that is not proved is that motor's next (as :class:`Ahead` would make it)."""
    if not proving.forked or proving.decided(k) or k in ready or k + 1 in ready:
        return
    j = k + 1 if proving.prover.likely(motors[k]) else k
    if j >= len(motors):
        return
    o = options
    made = prepare(with_motor(scene, motors[j]), o.get("starts", 20), o.get("seed", 0), o.get("settings"),
                   o.get("x_starts"))
    made.ahead_s = made.timings["build_s"] + made.timings["screen_s"]   # not in the optimise that uses it
    ready[j] = made


class Made:
    """A motor's :class:`~.multistart.Prepared` made beforehand, given as :class:`Ahead` gives it."""

    def __init__(self, prepared):
        self.prepared = prepared

    def result(self):
        return self.prepared


def proved_result(scene, proof, settings=None) -> OptimisationResult:
    """The result of a motor proved not to fit (no start run): unsuccessful, its message the proof's."""
    from .problem import SolverSettings

    return OptimisationResult(scene=scene, design={}, objective=None, objective_sampled=None, objective_kind="none",
                              peak_certified=None, peak_sampled=None, success=False, status="proved infeasible",
                              message=proof.message(), constraints={}, sensitivities={}, starts_total=0,
                              starts_at_best=0, starts=(), settings=settings or SolverSettings(),
                              start_plan={"method": "none: proved not to fit before its starts (energy bound)",
                                          "proof": proof.to_dict()})


class Ahead:
    """The next motor's problem built and its starts planned (:func:`.multistart.prepare`) in a
    thread while this motor's starts run in the worker processes (the command's own process
    waits for them: its build and screening, 4-5 s of crane_luffing_drive per motor, then no
    longer stand between two motors' starts).  Begun once ``AFTER`` starts of this motor have
    finished and none found a design: a motor that fits is the last one optimised, and the next
    would be built for nothing (of crane_luffing_drive's 7.5 kW motor, which fits, every start
    finds a design).  When none of this motor's planned start points was screened feasible at
    the sample points (the plan's ``fitting`` 0: crane_luffing_drive's 4 and 5.5 kW motors; its
    7.5 kW motor has 19), once the first start has finished without a design: the next motor's
    build then ends before this one's starts rather than after (begun after the first start,
    not before it: the workers are forked by then, not while the thread runs).  The same problem
    and plan as made in turn (the same code on the same scene)."""

    def __init__(self, scene, options):
        self.scene, self.options, self.started = scene, options, False
        self.seen_fit, self.seen = False, 0
        self.after = min(self.AFTER, options.get("starts", 20))
        self._done, self._thread = None, None

    AFTER = 3

    def planned(self, prepared):
        """This motor's problem is built and its starts planned (:class:`~.multistart.Prepared`)."""
        if prepared.plan.fitting == 0:
            self.after = 1

    def finished(self, report):
        """A start of this motor finished (called in the command's thread, the workers forked)."""
        import threading

        self.seen += 1
        self.seen_fit = self.seen_fit or report.success
        if self.started or self.seen_fit or self.seen < self.after:
            return
        self.started = True
        self._thread = threading.Thread(target=self._run, name="optdesign next motor", daemon=True)
        self._thread.start()

    def _run(self):
        from .multistart import prepare

        o = self.options
        try:
            self._done = ("ok", prepare(self.scene, o.get("starts", 20), o.get("seed", 0), o.get("settings"),
                                        o.get("x_starts"), ahead=True))
        except BaseException as exc:   # noqa: BLE001 - raised where the motor is optimised
            self._done = ("error", exc)

    def result(self):
        """The :class:`~.multistart.Prepared` of the next motor (waits for it), or its error."""
        self._thread.join()
        kind, value = self._done
        if kind == "error":
            raise value
        return value


def motor_order(scene) -> list:
    """The motors of the catalogue in the order tried: smallest rated torque first (then by name)."""
    values = scene.parameter_values()
    return sorted(scene.motors, key=lambda m: (motor_numbers(m, values)["rated_torque"], m.name))


def catalogue_scene(scene):
    """The scene whose analysis at the chosen design gives the catalogue's table of motors
    (report/drive_train.catalogue_analysis): every motor, in the order tried."""
    return dataclasses.replace(scene, motors=tuple(motor_order(scene)))


def with_motor(scene, motor):
    """``scene`` with ``motor`` alone for its catalogue; a duty cycle in time
    ([simulation] motor naming another motor of the catalogue) then runs that motor too: the
    catalogue is optimised with each motor in turn, the phases with the one being optimised
    (``simulate --design`` runs the motor the result chose)."""
    sim = scene.simulation
    if sim is not None and sim.motor is not None and sim.motor != motor.name:
        sim = dataclasses.replace(sim, motor=motor.name)
    return dataclasses.replace(scene, motors=(motor,), simulation=sim)


def interrupted_catalogue(motors, results, stop, proofs=None) -> OptimisationInterrupted:
    """Ctrl-C while the motor after those of ``results`` (decided, none fits) was optimised:
    ``stop`` (its :class:`~optdesign.errors.OptimisationInterrupted`, or a plain
    KeyboardInterrupt from before its starts) with ``catalogue``, the catalogue so far (its
    ``best`` None when nothing was decided)."""
    if not isinstance(stop, OptimisationInterrupted):
        stop = OptimisationInterrupted()
    motor = motors[len(results)].name
    results = dict(results)
    if stop.result is not None:   # the best design of its finished starts: feasible, so it fits
        results[motor] = stop.result
    chosen = motor if stop.result is not None and stop.result.success else None
    decided = [r for name, r in results.items() if name != motor]
    best = results[chosen] if chosen else (decided[-1] if decided else None)
    stop.catalogue = CatalogueResult(results, chosen, best, tuple(m.name for m in motors[len(decided) + 1:]),
                                     motor, (stop.finished, stop.total), tuple(motors), dict(proofs or {}))
    return stop
