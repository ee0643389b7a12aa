"""Derived equations of motion against closed forms and textbook results.

Each system is a model of the library (models/); the check is that the symbolic difference
between lagdsl's equations and the known ones simplifies to zero.
"""
import sympy

from tests.mechanics.eom import equations_from_text, equations_of, is_zero, residual_rows, solve_accelerations, symbols_of


def test_particle_in_3d_obeys_newton():
    eq = equations_of("particle_3d")
    s = symbols_of(eq)
    x, y, z, m, k, c = (s[n] for n in ("x", "y", "z", "m", "k", "c"))
    potential = k / 2 * (x**2 + y**2 + z**2) + c * x * y * z
    for row, q in zip(residual_rows(eq), (x, y, z)):
        assert is_zero(row - (m * s[q.name + "''"] + potential.diff(q)))     # m r'' = -grad U


def test_double_pendulum_matches_the_worksheet_not_the_notes():
    eq = equations_of("double_pendulum")
    s = symbols_of(eq)
    m1, m2, l1, l2, g = (s[n] for n in ("m1", "m2", "l1", "l2", "g"))
    t1, t2, w1, w2, a1, a2 = (s[n] for n in ("theta1", "theta2", "theta1'", "theta2'", "theta1''", "theta2''"))
    first = ((m1 + m2) * l1**2 * a1 + m2 * l1 * l2 * a2 * sympy.cos(t1 - t2)
             + m2 * l1 * l2 * w2**2 * sympy.sin(t1 - t2) + (m1 + m2) * g * l1 * sympy.sin(t1))
    second = (m2 * l2**2 * a2 + m2 * l1 * l2 * a1 * sympy.cos(t1 - t2)
              - m2 * l1 * l2 * w1**2 * sympy.sin(t1 - t2) + m2 * g * l2 * sympy.sin(t2))
    rows = residual_rows(eq)
    assert is_zero(rows[0] - first)
    assert is_zero(rows[1] - second)
    notes_second = m2 * l2**2 * a2 + m2 * l1 * l2 * a1 * sympy.cos(t1 - t2) - m2 * g * l2 * sympy.sin(t2)
    assert not is_zero(rows[1] - notes_second)          # the lecture notes' version is wrong
    assert [c.dropped for c in eq.constraints] == [True, True]


def test_wedge_accelerations():
    eq = equations_of("wedge")
    s = symbols_of(eq)
    M, m, alpha, g = (s[n] for n in ("M", "m", "alpha", "g"))
    xdd, sdd = solve_accelerations(eq)
    denominator = M + m * sympy.sin(alpha)**2
    assert is_zero(xdd + m * g * sympy.sin(alpha) * sympy.cos(alpha) / denominator)
    assert is_zero(sdd - (M + m) * g * sympy.sin(alpha) / denominator)
    assert {q.name for q in eq.conserved} == {"momentum(x)", "energy"}


def test_rolling_penny_with_multipliers():
    eq = equations_of("rolling_penny")
    s = symbols_of(eq)
    m, a, g, alpha = (s[n] for n in ("m", "a", "g", "alpha"))
    theta, wphi, wtheta = s["theta"], s["phi'"], s["theta'"]
    xdd, ydd, phidd, thetadd, mu1, mu2 = solve_accelerations(eq)
    assert is_zero(phidd + 2 * g * sympy.sin(alpha) * sympy.sin(theta) / (3 * a))
    assert thetadd == 0
    sa = sympy.sin(alpha)
    assert is_zero(mu1 - m * (2 * g * sa * sympy.sin(theta)**2 - 3 * g * sa
                              - 3 * a * sympy.cos(theta) * wphi * wtheta) / 3)
    assert is_zero(mu2 + m * sympy.sin(theta) * (3 * a * wphi * wtheta + 2 * g * sa * sympy.cos(theta)) / 3)
    assert [c.kind for c in eq.constraints] == ["nonholonomic", "nonholonomic"]
    # the constraints push on x, y and phi: only theta's momentum is conserved
    assert {q.name for q in eq.conserved} == {"momentum(theta)", "energy"}


def test_kepler_conserves_angular_momentum_and_energy():
    eq = equations_of("kepler")
    s = symbols_of(eq)
    r, w, m = s["r"], s["theta'"], s["m"]
    conserved = {q.name: q for q in eq.conserved}
    assert set(conserved) == {"momentum(theta)", "energy"}
    calculus = eq.calculus()
    assert is_zero(calculus.inline(conserved["momentum(theta)"].expression) - m * r**2 * w)


def test_heavy_top_conserves_two_momenta_and_energy():
    eq = equations_of("heavy_top")
    s = symbols_of(eq)
    I1, I3, m, g, l = (s[n] for n in ("I1", "I3", "m", "g", "l"))
    theta, wphi, wtheta, wpsi = s["theta"], s["phi'"], s["theta'"], s["psi'"]
    conserved = {q.name: q for q in eq.conserved}
    assert set(conserved) == {"momentum(phi)", "momentum(psi)", "energy"}
    calculus = eq.calculus()
    p_psi = I3 * (wpsi + wphi * sympy.cos(theta))
    p_phi = (I1 * sympy.sin(theta)**2 + I3 * sympy.cos(theta)**2) * wphi + I3 * wpsi * sympy.cos(theta)
    h = (I1 / 2 * (wtheta**2 + wphi**2 * sympy.sin(theta)**2) + I3 / 2 * (wpsi + wphi * sympy.cos(theta))**2
         + m * g * l * sympy.cos(theta))
    assert is_zero(calculus.inline(conserved["momentum(psi)"].expression) - p_psi)
    assert is_zero(calculus.inline(conserved["momentum(phi)"].expression) - p_phi)
    assert is_zero(calculus.inline(conserved["energy"].expression) - h)


def test_damped_driven_pendulum():
    eq = equations_of("damped_driven_pendulum")
    s = symbols_of(eq)
    m, l, g, b, A, omega, t = (s[n] for n in ("m", "l", "g", "b", "A", "omega", "t"))
    theta, w, acc = s["theta"], s["theta'"], s["theta''"]
    expected = m * l**2 * acc + m * g * l * sympy.sin(theta) + b * w - A * sympy.cos(omega * t)
    assert is_zero(residual_rows(eq)[0] - expected)
    assert eq.conserved == ()


def test_charged_particle_in_a_magnetic_field():
    eq = equations_of("charged_particle")
    s = symbols_of(eq)
    m, e, B = s["m"], s["e"], s["B"]
    rows = residual_rows(eq)
    assert is_zero(rows[0] - (m * s["x''"] - e * B * s["y'"]))
    assert is_zero(rows[1] - (m * s["y''"] + e * B * s["x'"]))
    assert is_zero(rows[2] - m * s["z''"])
    assert {q.name for q in eq.conserved} == {"momentum(z)", "energy"}


def test_pendulum_chain_mass_matrix():
    """M_kj = m l^2 (n - max(k, j) + 1) cos(theta_k - theta_j) for the uniform chain."""
    eq = equations_of("pendulum_chain")
    s = symbols_of(eq)
    n = eq.size
    m, l = s["m"], s["l"]
    calculus = eq.calculus()
    for k, j in [(0, 0), (0, 5), (3, 7), (11, 11)]:
        expected = m * l**2 * (n - max(k, j)) * sympy.cos(eq.coordinates[k] - eq.coordinates[j])
        assert is_zero(calculus.inline(eq.mass_matrix[k][j]) - expected)


def test_cartesian_pendulum_multiplier_is_the_rod_force():
    """g = x^2 + y^2 - l^2: m x'' = 2 λ x, m y'' = -m g + 2 λ y, λ = -m (v^2 - g y) / (2 l^2)."""
    eq = equations_of("cartesian_pendulum")
    s = symbols_of(eq)
    m, l, g = s["m"], s["l"], s["g"]
    x, y, vx, vy = s["x"], s["y"], s["x'"], s["y'"]
    xdd, ydd, lam = solve_accelerations(eq)
    on_circle = {y: -sympy.sqrt(l**2 - x**2)}
    expected = -m * (vx**2 + vy**2 - g * y) / (2 * l**2)
    assert is_zero((lam - expected).subs(on_circle))
    assert is_zero((m * xdd - 2 * lam * x).subs(on_circle))
    assert is_zero((m * ydd + m * g - 2 * lam * y).subs(on_circle))
    assert [c.dropped for c in eq.constraints] == [False]


def test_explicitly_time_dependent_lagrangian():
    """Kapitza's pendulum: l theta'' = -(g - A omega^2 cos(omega t)) sin(theta); h not conserved."""
    eq = equations_of("driven_support")
    s = symbols_of(eq)
    m, l, g, A, omega, t = (s[n] for n in ("m", "l", "g", "A", "omega", "t"))
    theta, acc = s["theta"], s["theta''"]
    expected = m * l**2 * acc + m * l * (g - A * omega**2 * sympy.cos(omega * t)) * sympy.sin(theta)
    assert is_zero(residual_rows(eq)[0] - expected)
    assert eq.conserved == ()


BEAD_ON_A_TURNING_ROD = """
model TurningRod "a bead on a rod turned in a horizontal plane at the constant rate omega"
  parameter m = 1 [kg];
  parameter omega = 2 [rad/s];
  coordinate x(start = 1) [m];
  coordinate y(start = 0) [m];
  T = m/2*(der(x)^2 + der(y)^2);
  U = 0;
  constraint rod: cos(omega*t)*y - sin(omega*t)*x = 0;
end TurningRod;
"""


def test_bead_on_a_turning_rod_is_flung_out_and_pushed_by_the_coriolis_force():
    """A rheonomic constraint: the rod through the origin at the angle omega t. Along the rod
    r'' = omega^2 r (r = r0 cosh(omega t) + ...); across it the rod pushes with
    lambda = 2 m omega r', the Coriolis force, so x'' = -2 omega r' sin(omega t) and
    y'' = 2 omega r' cos(omega t): the bead on a rotating rod of the textbooks' chapters on
    rotating frames (e.g. J. R. Taylor, Classical Mechanics, chapters 7 and 9)."""
    eq = equations_from_text(BEAD_ON_A_TURNING_ROD)
    s = symbols_of(eq)
    m, omega, t = s["m"], s["omega"], s["t"]
    r, speed = sympy.symbols("r speed", real=True)
    angle = omega * t
    on_rod = {s["x"]: r * sympy.cos(angle), s["y"]: r * sympy.sin(angle),
              s["x'"]: speed * sympy.cos(angle) - r * omega * sympy.sin(angle),
              s["y'"]: speed * sympy.sin(angle) + r * omega * sympy.cos(angle)}
    xdd, ydd, lam = (expression.subs(on_rod) for expression in solve_accelerations(eq))
    assert is_zero(lam - 2 * m * omega * speed)
    assert is_zero(xdd + 2 * omega * speed * sympy.sin(angle))
    assert is_zero(ydd - 2 * omega * speed * sympy.cos(angle))
    assert [c.kind for c in eq.constraints] == ["holonomic"] and eq.conserved == ()
