"""kinematics.batches.parameters_used, which decides which cases of a batch share a computation
(the assembly check, the dead-centre check, the certification's aggregate rows): a parameter read
only through an operation of zero derivative (floor, a comparison inside if_else) counts as read,
so cases that differ in it are never given each other's numbers."""
import casadi as ca
import numpy as np

from optdesign.kinematics.batches import parameters_used, same_cases


class _Mech:
    def __init__(self, sym):
        self.s, self.p = sym.sym("s"), sym.sym("p", 4)


def test_parameters_read_through_floor_and_comparisons_count():
    for sym in (ca.SX, ca.MX):
        m = _Mech(sym)
        p = m.p
        rows = ca.vertcat(m.s * ca.floor(p[0]), ca.if_else(p[1] > 0.5, m.s, 2 * m.s), m.s ** 2)
        assert list(parameters_used(m, rows)) == [0, 1], sym
        assert list(parameters_used(m, m.s * p[3])) == [3], sym
    # cases equal in the parameters read share; one that differs only in floor's argument does not
    P = np.array([[1.2, 0.1, 5.0, 0.0], [1.2, 0.1, 7.0, 1.0], [1.7, 0.1, 5.0, 0.0]])
    assert same_cases(P, np.array([0, 1])) == [(0, [0, 1]), (2, [2])]
