"""The four problems of heyoka_comparison.py as a heyoka user writes them: the equations of
motion by hand, each as heyoka's documentation and examples write such systems (the double
pendulum's accelerations solved by Cramer's rule, the bodies' accelerations as sums over
pairs, heyoka's own N-body model for the solar system).

Each function returns (system, initial state, columns): the list of (variable, derivative)
heyoka's taylor_adaptive takes, the state in its order, and for each output column of the
lagdsl scene the index of the state entry that holds it.
"""
from __future__ import annotations

import math


def double_pendulum(m1=1.0, m2=1.0, l1=1.0, l2=1.0, g=9.81, theta1=1.0, theta2=2.0):
    import heyoka as hy
    th1, th2, w1, w2 = hy.make_vars("th1", "th2", "w1", "w2")
    d = th1 - th2
    s, c = hy.sin(d), hy.cos(d)
    # M q'' = b with M = [[(m1 + m2) l1², m2 l1 l2 c], [m2 l1 l2 c, m2 l2²]], solved by Cramer's rule
    a11, a12, a22 = (m1 + m2) * l1 * l1, m2 * l1 * l2 * c, m2 * l2 * l2
    b1 = -m2 * l1 * l2 * s * w2 * w2 - (m1 + m2) * g * l1 * hy.sin(th1)
    b2 = m2 * l1 * l2 * s * w1 * w1 - m2 * g * l2 * hy.sin(th2)
    det = a11 * a22 - a12 * a12
    system = [(th1, w1), (th2, w2), (w1, (b1 * a22 - a12 * b2) / det), (w2, (a11 * b2 - a12 * b1) / det)]
    return system, [theta1, theta2, 0.0, 0.0], {"theta1": 0, "theta2": 1}


def pleiades():
    """Hairer's seven stars in a plane, star i of mass i, G = 1 (the IVP test set's plei)."""
    import heyoka as hy
    n = 7
    x = hy.make_vars(*[f"x{i}" for i in range(n)])
    y = hy.make_vars(*[f"y{i}" for i in range(n)])
    vx = hy.make_vars(*[f"vx{i}" for i in range(n)])
    vy = hy.make_vars(*[f"vy{i}" for i in range(n)])
    ax, ay = [[] for _ in range(n)], [[] for _ in range(n)]
    for i in range(n):
        for j in range(i + 1, n):
            dx, dy = x[j] - x[i], y[j] - y[i]
            r3 = (dx * dx + dy * dy) ** -1.5
            ax[i].append((j + 1) * dx * r3)
            ay[i].append((j + 1) * dy * r3)
            ax[j].append(-(i + 1) * dx * r3)
            ay[j].append(-(i + 1) * dy * r3)
    system = [(x[i], vx[i]) for i in range(n)] + [(y[i], vy[i]) for i in range(n)]
    system += [(vx[i], hy.sum(ax[i])) for i in range(n)] + [(vy[i], hy.sum(ay[i])) for i in range(n)]
    return (system, *pleiades_start()[1:])


def pleiades_start():
    """(the number of stars, the state (x, y, vx, vy; seven each), the columns)."""
    n = 7
    start = [3, 3, -1, -3, 2, -2, 2, 3, -3, 2, 0, 0, -4, 4] + [0, 0, 0, 0, 0, 1.75, -1.5, 0, 0, 0, -1.25, 1, 0, 0]
    columns = {f"x[{i + 1}]": i for i in range(n)} | {f"y[{i + 1}]": n + i for i in range(n)}
    return n, [float(v) for v in start], columns


def outer_solar_system(model):
    """heyoka's N-body model with the masses, G and start of models/outer_solar_system.lag
    (read from the lagdsl model, so both integrate the same numbers)."""
    import heyoka as hy
    masses, gravity, state, columns = solar_system_data(model)
    return hy.model.nbody(len(masses), masses=masses, Gconst=gravity), state, columns


def solar_system_data(model):
    """(masses, G, state, columns) of the model's scene book: state (x, y, z, vx, vy, vz) per
    body, heyoka's nbody layout."""
    names = [p.name for p in model.ir.parameters]
    values = dict(zip(names, model.plan("book").parameters))
    masses = [values[f"m{i}"] for i in range(6)]
    y0 = model.plan("book").initial_state                 # (x[1..6], y[1..6], z[1..6], then velocities)
    state, columns = [], {}
    for body in range(6):
        for axis, name in enumerate("xyz"):
            columns[f"{name}[{body + 1}]"] = len(state)
            state.append(y0[6 * axis + body])
        state += [y0[18 + 6 * axis + body] for axis in range(3)]
    return masses, values["G"], state, columns


def kepler_polar(eccentricity: float):
    """Kepler's problem in polar coordinates, GM = 1, from periapsis r = 1: the equations the
    lagdsl model derives, r'' = r θ'² - 1/r², θ'' = -2 r' θ' / r."""
    import heyoka as hy
    r, th, vr, vth = hy.make_vars("r", "th", "vr", "vth")
    system = [(r, vr), (th, vth), (vr, r * vth * vth - 1.0 / (r * r)), (vth, -2.0 * vr * vth / r)]
    return system, [1.0, 0.0, 0.0, math.sqrt(1 + eccentricity)], {"r": 0, "theta": 1}
