"""An independent numpy model of problems/transfer_arm.toml and its global optimum for one motor
of the catalogue (nothing of optdesign is imported: the geometry, the virtual work, the s-curve
in time, the drive train and the constraints are written here from the scene and
docs/scenes.md, "Sizing the drive").

Crank-rocker: O = (0, 0), A = r e^{i phi}, Q = (xQ, yQ), B at c from A and R from Q, left of
the directed line A -> Q (the two circles' intersection), the rocker angle psi = arg(B - Q).
Bodies: the arm (mass mA at La/2 along Q -> B, inertia mA La^2/12), the part (mP at La, a point)
and the coupler (mC = 2.5 c at the middle of A B, inertia mC c^2/12); gravity -g y.  The ideal
crank torque by virtual work (d'Alembert): T = sum m r'.(r'' phid^2 + r' phidd) + I th'
(th'' phid^2 + th' phidd) + m g y', the derivatives d/dphi in closed form (the loop closure
differentiated by hand, smooth in the design to round-off).  The drive train: T_S = T/eta_m while the crank drives (T
phid > 0), T eta_m while the power flows back; the motor torque T_m = c_g T_S/i + J_r i phidd
(c_g likewise 1/eta_g or eta_g), the motor speed i phid.

The profile: the s-curve (jerk j, acceleration a, speed v, seven phases in time) over one crank
turn from rest to rest; the cases transfer (mP = 8), return empty (0), heavy part (12), every
one forward.  The duty cycle: transfer, 0.3 s dwell, return empty, 0.3 s dwell; its RMS motor
torque sqrt(int T_m^2 dt / T) by Gauss-Legendre in time, split at the phases and where T
changes sign (the efficiencies switch there).

Constraints: the rocker's swing (closed form: its extremes lie where the crank and coupler are
in line, |OB| = c + r and c - r) equal to 60 deg; the transmission angle at B (closed form: its
extremes where A is on the line O Q, cos mu = (c^2 + R^2 - |QA|^2)/(2 c R)) in 40 .. 140 deg;
the motor's peak torque, rated torque (RMS over the cycle) and speed.  The global optimum: a
grid of (r, xQ) with c solved from the swing equality, times a grid of i, then polished SLSQP
solves (epigraph on the peak, refined peaks exchanged in)."""
from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
from scipy.optimize import brentq, minimize, minimize_scalar

SCENE = Path(__file__).resolve().parents[1] / "problems" / "transfer_arm.toml"
DEG = math.pi / 180
YQ, R, LA, MA, G = 0.05, 0.25, 0.5, 5.0, 9.81
ETA_M, ETA_G = 0.95, 0.9
V, ACC, JERK = 600 * DEG, 5000 * DEG, 150000 * DEG
SWING, MU = 60 * DEG, (40 * DEG, 140 * DEG)
CASES = (("transfer", 8.0), ("return empty", 0.0), ("heavy part", 12.0))
DWELLS = 0.6
NAMES = ("r", "c", "xQ", "i")
BOX = {"r": (0.05, 0.2), "c": (0.25, 0.8), "xQ": (0.25, 0.7), "i": (3.0, 60.0)}
MOTORS = {"servo 400 W": (0.000067, 1.27, 3.8, 314.0), "servo 750 W": (0.00015, 2.39, 7.1, 314.0),
          "servo 1.5 kW": (0.00031, 4.77, 14.3, 314.0)}     # inertia, rated, peak, max speed


def scene_numbers():
    data = tomllib.loads(SCENE.read_text())
    p = data["parameters"]
    prof = data["profiles"]["index"]
    return {"fixed": (p["yQ"], p["R"], p["La"], p["mA"], data["gravity"]["g"]),
            "eta": (data["drive"]["efficiency"], data["gearbox"]["efficiency"]),
            "profile": (prof["kind"], prof["speed"], prof["acceleration"], prof["deceleration"], prof["jerk"]),
            "box": {n: (p[n]["min"], p[n]["max"]) for n in NAMES},
            "cases": [(c["name"], float(c.get("set", {}).get("mP", p["mP"]))) for c in data["cases"]],
            "motors": {m["name"]: (m["inertia"], m["rated_torque"], m["peak_torque"], m["max_speed"])
                       for m in data["motors"]},
            "duty": data["duty"]["cycle"]}


# --- the s-curve in time ------------------------------------------------------------------------
def phases():
    """[(duration, jerk)] of the seven phases over one crank turn."""
    tj = ACC / JERK
    ta = V / ACC - tj
    x_acc = V * (2 * tj + ta) / 2
    tc = (2 * math.pi - 2 * x_acc) / V
    return [(tj, JERK), (ta, 0.0), (tj, -JERK), (tc, 0.0), (tj, -JERK), (ta, 0.0), (tj, JERK)]


def phase_starts():
    """(t0, x0, v0, a0, duration, jerk) of each phase."""
    out, t, x, v, a = [], 0.0, 0.0, 0.0, 0.0
    for d, j in phases():
        out.append((t, x, v, a, d, j))
        x, v, a, t = x + v * d + a * d * d / 2 + j * d ** 3 / 6, v + a * d + j * d * d / 2, a + j * d, t + d
    return out


def state(p, tau):
    """phi, phid, phidd at time tau into phase p."""
    _, x, v, a, _, j = p
    return x + v * tau + a * tau ** 2 / 2 + j * tau ** 3 / 6, v + a * tau + j * tau ** 2 / 2, a + j * tau


# --- kinematics and virtual work ----------------------------------------------------------------
def positions(r, c, xQ, phi):
    """A, B (complex) for designs broadcast against phi; NaN where the linkage does not assemble."""
    A = r * np.exp(1j * phi)
    Q = xQ + 1j * YQ
    d = np.abs(Q - A)
    a = (c ** 2 - R ** 2 + d ** 2) / (2 * d)
    with np.errstate(invalid="ignore"):
        h = np.sqrt(c ** 2 - a ** 2)
    e = (Q - A) / d
    return A, A + a * e + h * 1j * e


def ideal_torque(r, c, xQ, phi, phid, phidd):
    """The crank torque of the ideal mechanism, split as (T without the part, T per kg of part).
    The derivatives d/dphi in closed form (the dyad's loop closure differentiated by hand): the
    rocker turns at lam = B'/(i w) with w = B - Q, where u = B - A keeps its length (Re(u* u')
    = 0) and w its own (B' = i lam w); differentiated once more for the angular acceleration mu.
    (Finite differences of the positions are not smooth in the design at the 1e-8 level: a
    search's gradients would be noise there.)"""
    A, B = positions(r, c, xQ, phi)
    Q = xQ + 1j * YQ
    A1, A2 = 1j * A, -A
    u, w = B - A, B - Q
    den = (np.conj(u) * 1j * w).real
    lam = (np.conj(u) * A1).real / den                      # rocker angle's d/dphi
    B1 = 1j * lam * w
    u1 = B1 - A1
    mu = ((np.conj(u) * (lam ** 2 * w + A2)).real - np.abs(u1) ** 2) / den
    B2 = 1j * mu * w - lam ** 2 * w
    u2 = B2 - A2
    cc = np.abs(u) ** 2
    th1, th2 = (np.conj(u) * u1).imag / cc, (np.conj(u) * u2).imag / cc   # coupler angle's
    mC = 2.5 * c

    def term(d1, d2, m, inertia=0.0, a1=0.0, a2=0.0):
        acc = d2 * phid ** 2 + d1 * phidd
        t = m * (d1.real * acc.real + d1.imag * acc.imag) + m * G * d1.imag
        return t + inertia * a1 * (a2 * phid ** 2 + a1 * phidd)

    base = (term(LA / (2 * R) * B1, LA / (2 * R) * B2, MA, MA * LA ** 2 / 12, lam, mu)     # the arm
            + term((A1 + B1) / 2, (A2 + B2) / 2, mC, mC * c ** 2 / 12, th1, th2))          # the coupler
    part = term(LA / R * B1, LA / R * B2, 1.0)
    return base, part


def motor_torque(T, phid, phidd, i, J):
    flow = np.where(T * np.where(phid == 0, 1.0, phid) > 0, 1 / (ETA_M * ETA_G), ETA_M * ETA_G)
    return flow * T / i + J * i * phidd


# --- per design: peak, RMS over the cycle, constraints ------------------------------------------
def case_torques(x, tau_n=41):
    """Per case, the ideal torque on tau_n samples of each phase (ends from both sides) and the
    motion there: {case: (T, phid, phidd)}."""
    r, c, xQ = x[:3]
    cols = [state(p, np.linspace(0, p[4], tau_n)) for p in phase_starts()]
    phi, phid, phidd = (np.concatenate([col[k] for col in cols]) for k in range(3))
    base, part = ideal_torque(r, c, xQ, phi, phid, phidd)
    return {name: (base + m * part, phid, phidd) for name, m in CASES}


def peak_torque(x, J, tau_n=401, refine=True, within=None, cases=CASES):
    """The largest |T_m| over the cases' continuous motion (each local maximum refined in time):
    (value, case, time); with ``within`` a fraction, also every refined local maximum within it
    of the peak, as a 4th item [(value, case, phase index, tau)]."""
    found = []
    for name, m in cases:
        for j, p in enumerate(phase_starts()):
            tau = np.linspace(0, p[4], tau_n)
            f = np.abs(_tm(x, p, tau, m, J))
            cands = [k for k in range(tau_n) if (k == 0 or f[k] >= f[k - 1]) and (k == tau_n - 1 or f[k] >= f[k + 1])]
            for k in cands:
                val, at = f[k], tau[k]
                if refine and 0 < k < tau_n - 1:
                    res = minimize_scalar(lambda t: -abs(float(_tm(x, p, np.array([t]), m, J)[0])),
                                          bounds=(tau[k - 1], tau[k + 1]), method="bounded", options={"xatol": 1e-13})
                    if -res.fun > val:
                        val, at = -res.fun, res.x
                found.append((float(val), name, j, float(at)))
    value, case, j, at = max(found)
    best = (value, case, phase_starts()[j][0] + at)
    if within is None:
        return best
    return best + ([f for f in found if f[0] >= (1 - within) * value],)


def _tm(x, p, tau, m, J):
    phi, phid, phidd = state(p, tau)
    base, part = ideal_torque(x[0], x[1], x[2], phi, phid, phidd)
    return motor_torque(base + m * part, phid, phidd, x[3], J)


def squared_integral(x, m, J, nodes=12, panels=8):
    """int T_m^2 dt over one stroke of a case: Gauss-Legendre on each phase's panels, split where
    the ideal torque changes sign (bisected to round-off)."""
    g, w = np.polynomial.legendre.leggauss(nodes)
    total = 0.0
    for p in phase_starts():
        edges = np.linspace(0, p[4], panels * 8 + 1)
        phi, phid, phidd = state(p, edges)
        base, part = ideal_torque(x[0], x[1], x[2], phi, phid, phidd)
        T = base + m * part
        cuts = [0.0]
        for k in np.nonzero(np.sign(T[:-1]) * np.sign(T[1:]) < 0)[0]:
            def f(t):
                ph, pd, pdd = state(p, np.array([t]))
                b_, p_ = ideal_torque(x[0], x[1], x[2], ph, pd, pdd)
                return float((b_ + m * p_)[0])
            cuts.append(brentq(f, edges[k], edges[k + 1], xtol=1e-15))
        cuts.append(p[4])
        for lo, hi in zip(cuts[:-1], cuts[1:]):
            e = np.linspace(lo, hi, panels + 1)
            mid, half = (e[1:] + e[:-1]) / 2, (e[1:] - e[:-1]) / 2
            tau = (mid[:, None] + half[:, None] * g[None, :]).ravel()
            tm = _tm(x, p, tau, m, J)
            total += float(np.sum((tm ** 2).reshape(panels, nodes) * half[:, None] * w[None, :]))
    return total


def cycle_time():
    return 2 * sum(d for d, _ in phases()) + DWELLS


def rms(x, J):
    masses = dict(CASES)
    return math.sqrt((squared_integral(x, masses["transfer"], J) + squared_integral(x, masses["return empty"], J))
                     / cycle_time())


def extremes_positions(r, c, xQ):
    """B where the crank and coupler are in line (|OB| = c + r, c - r), on the assembly's side."""
    Q = xQ + 1j * YQ
    out = []
    for rho, sign in ((c + r, 1.0), (c - r, -1.0)):
        d = abs(Q)
        a = (rho ** 2 - R ** 2 + d ** 2) / (2 * d)
        h = math.sqrt(max(rho ** 2 - a ** 2, 0.0))
        e = Q / d
        picks = []
        for s in (1, -1):
            B = a * e + s * h * 1j * e
            A = sign * r * B / abs(B)
            cross = ((Q - A).conjugate() * (B - A)).imag
            if cross > 0:
                picks.append(B)
        out.append(picks)
    return out


def swing(r, c, xQ):
    """max - min of angle(G, Q, B) over a crank turn (closed form); NaN if not a crank-rocker."""
    Q = xQ + 1j * YQ
    d = abs(Q)
    if not (c + R >= d + r and abs(c - R) <= d - r):
        return math.nan
    ext, ang = extremes_positions(r, c, xQ), []
    for picks in ext:
        if len(picks) != 1:
            return math.nan
        ang.append(abs(np.angle(picks[0] - Q)))
    return abs(ang[0] - ang[1])


def transmission(r, c, xQ):
    """(min, max) of the transmission angle at B over a crank turn (closed form)."""
    d = math.hypot(xQ, YQ)
    mus = [math.acos(np.clip((c ** 2 + R ** 2 - qa ** 2) / (2 * c * R), -1, 1)) for qa in (d - r, d + r)]
    return min(mus), max(mus)


def violation(x, motor):
    """The constraints as values >= 0 when met (the swing as an equality apart)."""
    J, rated, peak_limit, speed = MOTORS[motor]
    lo, hi = transmission(*x[:3])
    return {"mu min": lo - MU[0], "mu max": MU[1] - hi, "speed": speed - x[3] * V,
            "rated": rated - rms(x, J), "peak": peak_limit - peak_torque(x, J)[0]}


# --- the global search --------------------------------------------------------------------------
def _c_roots(r, xQ, n=111):
    """Every coupler length c in its range with a swing of exactly 60 deg (brentq on a scan)."""
    cs = np.linspace(*BOX["c"], n)
    g = np.array([swing(r, c, xQ) - SWING for c in cs])
    out = []
    for k in range(n - 1):
        if np.isfinite(g[k]) and np.isfinite(g[k + 1]) and g[k] * g[k + 1] <= 0:
            out.append(brentq(lambda c: swing(r, c, xQ) - SWING, cs[k], cs[k + 1], xtol=1e-15))
    return out


def grid(motor, n=(61, 31), ni=115, tau_n=21):
    """Every grid design (r, c, xQ) on the swing equality times a grid of i, with its sampled
    peak |T_m| and whether it meets the swing, transmission angle and speed (``ok``) and the
    motor's rated (trapezoid-rule RMS) and peak torque (``meets``): (designs (m, 4), peak, ok,
    meets)."""
    J, rated, peak_limit, speed = MOTORS[motor]
    i_grid = np.linspace(*BOX["i"], ni)
    designs, peaks, ok, meets = [], [], [], []
    starts = phase_starts()
    t = np.concatenate([p[0] + np.linspace(0, p[4], tau_n) for p in starts])
    for r in np.linspace(*BOX["r"], n[0]):
        for xQ in np.linspace(*BOX["xQ"], n[1]):
            for c in _c_roots(r, xQ):
                lo, hi = transmission(r, c, xQ)
                if lo < MU[0] or hi > MU[1]:
                    continue
                cols = case_torques([r, c, xQ], tau_n)
                pk = np.zeros(ni)
                sq = np.zeros(ni)
                for name, (T, phid, phidd) in cols.items():
                    tm = motor_torque(T[None, :], phid, phidd, i_grid[:, None], J)
                    pk = np.maximum(pk, np.max(np.abs(tm), axis=1))
                    if name != "heavy part":
                        sq += np.trapezoid(tm ** 2, t, axis=1)
                rms_ = np.sqrt(sq / cycle_time())
                for k, i in enumerate(i_grid):
                    designs.append((r, c, xQ, i))
                    peaks.append(pk[k])
                    ok.append(i * V <= speed)   # the rated and peak torque: checked at the optimum
                    meets.append(rms_[k] <= rated and pk[k] <= peak_limit)
    return np.array(designs), np.array(peaks), np.array(ok), np.array(meets)


def polish(x0, motor, tau_n=31, rounds=6):
    """SLSQP on (r, c, xQ, i, t): min t, t >= |T_m| at every case's samples (and each refined
    peak found so far), the swing equality, the transmission angle and the motor's speed;
    repeated until the refined continuous peak is the epigraph's.  The motor's rated and peak
    torque are left out (checked at the optimum: a relaxation whose optimum meets them)."""
    J, rated, peak_limit, speed = MOTORS[motor]
    starts = phase_starts()
    extra = []   # (mass, phase, tau)

    def tms(z):
        out = []
        for _, m in CASES:
            for p in starts:
                out.append(np.abs(_tm(z, p, np.linspace(0, p[4], tau_n), m, J)))
        out += [np.abs(_tm(z, starts[k], np.array([tau]), m, J)) for m, k, tau in extra]
        return np.concatenate(out)

    z = np.array(list(x0) + [peak_torque(x0, J, 101, refine=False)[0]])
    for _ in range(rounds):
        cons = [{"type": "eq", "fun": lambda z: np.array([swing(*z[:3]) - SWING])},
                {"type": "ineq", "fun": lambda z: z[4] - tms(z)},
                {"type": "ineq", "fun": lambda z: np.array([transmission(*z[:3])[0] - MU[0],
                                                             MU[1] - transmission(*z[:3])[1],
                                                             (speed - z[3] * V) / speed])}]
        res = minimize(lambda z: z[4], z, method="SLSQP", constraints=cons,
                       bounds=[BOX[n] for n in NAMES] + [(0, None)], options={"ftol": 1e-15, "maxiter": 300})
        moved = np.max(np.abs(res.x[:4] - z[:4]) / np.array([hi - lo for lo, hi in BOX.values()]))
        z = res.x
        value, _, _, near = peak_torque(z[:4], J, within=0.02)
        extra.extend((dict(CASES)[case], j, tau) for _, case, j, tau in near)
        if value <= z[4] * (1 + 1e-10) and moved < 1e-9:
            break
    return z[:4], peak_torque(z[:4], J)[0]


def track(x0, motor, rounds=40):
    """The polish's second stage, from ``x0``: SLSQP steps on (r, c, xQ, i, t) inside a trust
    box (a fraction of the design box around the current design, halved when a step does not
    lower the continuous peak) with t >= each tracked local maximum of |T_m| in time (every one
    within 5 % of the peak, each the maximum over a window of +-2 % of its phase around where it
    was found, refined by a bounded scalar search: smooth in the design by the envelope
    theorem), the swing equality, the transmission angle and the speed; until the trust box is
    below 1e-9 of the design box."""
    J, _, _, speed = MOTORS[motor]
    starts = phase_starts()
    span = np.array([hi - lo for lo, hi in BOX.values()])
    x, value, delta = np.asarray(x0, float), peak_torque(x0, J)[0], 1e-2
    for _ in range(rounds):
        _, _, _, near = peak_torque(x, J, within=0.05)
        tracked = [(dict(CASES)[case], j, tau) for _, case, j, tau in near]

        def peaks(z, tracked=tracked):
            out = []
            for m, j, tau in tracked:
                p = starts[j]
                w = 0.02 * p[4]
                lo, hi = max(tau - w, 0.0), min(tau + w, p[4])
                f = lambda t: -abs(float(_tm(z, p, np.array([t]), m, J)[0]))
                res = minimize_scalar(f, bounds=(lo, hi), method="bounded", options={"xatol": 1e-14})
                out.append(max(-res.fun, -f(lo), -f(hi)))
            return np.array(out)

        cons = [{"type": "eq", "fun": lambda z: np.array([swing(*z[:3]) - SWING])},
                {"type": "ineq", "fun": lambda z: z[4] - peaks(z)},
                {"type": "ineq", "fun": lambda z: np.array([transmission(*z[:3])[0] - MU[0],
                                                             MU[1] - transmission(*z[:3])[1],
                                                             (speed - z[3] * V) / speed])}]
        box = [(max(lo, xi - delta * s_), min(hi, xi + delta * s_)) for (lo, hi), xi, s_ in zip(BOX.values(), x, span)]
        res = minimize(lambda z: z[4], np.append(x, value), method="SLSQP", constraints=cons,
                       bounds=box + [(0, None)], options={"ftol": 1e-15, "maxiter": 200})
        trial = peak_torque(res.x[:4], J)[0]
        if abs(swing(*res.x[:3]) - SWING) <= 1e-12 and trial < value:
            x, value = res.x[:4], trial
            delta = min(2 * delta, 1e-2) if np.max(np.abs(res.x[:4] - x) / span) >= 0.9 * delta else delta
        else:
            delta /= 4
        if delta < 1e-9:
            break
    return x, value


def global_optimum(motor, n=(61, 31), polished=3):
    """The best of SLSQP polishes from the best grid designs (swing, transmission angle and
    speed met) lying apart (1/20 of the box): {"design", "peak", "grid_best", "violation" (the
    worst of every constraint, the motor's torques included: >= 0 when met)}."""
    X, f, ok, _ = grid(motor, n)
    if not ok.any():
        return None
    order = np.argsort(np.where(ok, f, np.inf))
    span = np.array([hi - lo for lo, hi in BOX.values()])
    picks = []
    for k in order:
        if not ok[k] or len(picks) >= polished:
            break
        if all(np.max(np.abs(X[k] - X[j]) / span) > 0.05 for j in picks):
            picks.append(k)
    best = None
    for k in picks:
        z, value = track(polish(X[k], motor)[0], motor)
        v = violation(z, motor)
        kept = min(v["mu min"], v["mu max"], v["speed"], -abs(swing(*z[:3]) - SWING))
        if kept >= -1e-9 and (best is None or value < best[1]):
            best = (z, value, min(min(v.values()), kept))
    z, value, worst = best
    return {"design": dict(zip(NAMES, map(float, z))), "peak": value, "grid_best": float(f[order[0]]),
            "violation": worst}
