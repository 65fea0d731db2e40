"""Rigid segment walls with Coulomb friction (spfem_core.contact).

Single particles are driven by the time loop's own leapfrog (``integration.leapfrog``) with no
internal force: v += g dt; walls; x += v dt.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spfem_core.contact import wall_contact_velocity
from spfem_core.integration import leapfrog
from spfem_core.state import LEAPFROG_OUT_WIDTH

G = 9.81
DT = 1e-3
REACH = 0.05


def walls(*rows, mu=0.0):
    wall_xy = np.array(rows, dtype=np.float64).reshape(-1, 4)
    return wall_xy, np.full(wall_xy.shape[0], mu, dtype=np.float64)


def step(xy, v, wall_xy, wall_friction, fixed=None, gravity=(0.0, -G), dt=DT, reach=REACH):
    """One leapfrog step of free particles (unit mass, no internal force, no damping) in place;
    returns (contact flags, particles touching).  Fixed directions keep their velocity."""
    n = xy.shape[0]
    fixed = np.zeros((n, 2), dtype=bool) if fixed is None else fixed
    contact = np.zeros(n, dtype=np.int64)
    out = np.zeros(LEAPFROG_OUT_WIDTH)
    leapfrog(xy, np.zeros((n, 2)), v, np.zeros((n, 2)), np.ones(n), np.ones(n), fixed, v.copy(), np.zeros((n, 3)),
             np.zeros(0, dtype=np.int64), np.array(gravity, dtype=float),
             0.0, dt, wall_xy, wall_friction, reach, contact, out, 1)
    return contact, int(out[5])


def drop(xy, v, wall_xy, wall_friction, n_steps, gravity=(0.0, -G), dt=DT, reach=REACH):
    """Free flight under gravity with walls; returns the position and velocity histories, the
    contact flags and the velocity change the walls made in every step (all (n_steps, n, ...))."""
    xy = np.array(xy, dtype=np.float64).reshape(-1, 2)
    v = np.array(v, dtype=np.float64).reshape(-1, 2)
    g = np.array(gravity)
    xs, vs, flags, wall_dvs = [], [], [], []
    for _ in range(n_steps):
        free_flight = v + g * dt
        contact, _ = step(xy, v, wall_xy, wall_friction, gravity=gravity, dt=dt, reach=reach)
        xs.append(xy.copy())
        vs.append(v.copy())
        flags.append(contact)
        wall_dvs.append(v - free_flight)
    return np.array(xs), np.array(vs), np.array(flags), np.array(wall_dvs)


def test_dropped_particle_lands_without_bounce_and_rests_on_the_floor():
    floor, mu = walls((-10.0, 0.0, 10.0, 0.0), mu=0.3)
    n_steps = 2000  # 2 s; lands at t = sqrt(2 h / g) = 0.319 s
    xs, vs, flags, wall_dvs = drop([0.0, 0.5], [0.0, 0.0], floor, mu, n_steps)
    dvns = wall_dvs[:, :, 1]  # the floor's normal is +y
    y = xs[:, 0, 1]
    assert y.min() >= -1e-12  # never below the floor
    landed = int(np.argmax(flags[:, 0]))
    assert landed == pytest.approx(math.sqrt(2 * 0.5 / G) / DT, abs=2)
    assert abs(y[landed]) < 1e-12  # lands exactly on the wall at the end of the contact step
    assert np.all(flags[landed:, 0] == 1)  # stays in contact: no bounce
    assert np.all(np.abs(vs[landed + 1 :, 0]) < 1e-9)  # at rest from the next step on
    assert np.all(np.abs(y[landed:]) < 1e-12)
    # the step after landing removes the impact velocity (the approach speed, no bounce); from
    # then on the floor carries the weight: dv_n = g dt per step, so its normal impulse over a
    # time t at rest is m g t, and over the whole drop it balances gravity's (rest to rest)
    mass = 2.7
    impact_speed = -vs[landed, 0, 1]
    assert dvns[landed + 1, 0] == pytest.approx(impact_speed + G * DT, rel=1e-12)
    np.testing.assert_allclose(dvns[landed + 2 :, 0], G * DT, rtol=1e-9)
    rest_time = (n_steps - landed - 2) * DT
    assert mass * dvns[landed + 2 :, 0].sum() == pytest.approx(mass * G * rest_time, rel=1e-9)
    assert mass * dvns[:, 0].sum() == pytest.approx(mass * G * n_steps * DT, rel=1e-9)


def incline(theta, mu, length=100.0):
    c, s = math.cos(theta), math.sin(theta)
    return walls((0.0, 0.0, length * c, length * s), mu=mu)


@pytest.mark.parametrize("theta_deg", [20.0, 35.0])
def test_sliding_on_an_incline_accelerates_at_g_sin_minus_mu_cos(theta_deg):
    theta = math.radians(theta_deg)
    mu = 0.5 * math.tan(theta)
    wall_xy, wall_friction = incline(theta, mu)
    t_hat = np.array([math.cos(theta), math.sin(theta)])
    start = 50.0 * t_hat  # on the slope, at rest
    n_steps = 1000
    xs, vs, flags, _ = drop(start, [0.0, 0.0], wall_xy, wall_friction, n_steps)
    assert np.all(flags[:, 0] == 1)
    n_hat = np.array([-t_hat[1], t_hat[0]])
    gaps = (xs[:, 0] - 0.0) @ n_hat
    assert np.all(np.abs(gaps) < 1e-9)  # stays on the slope
    speed_down = -(vs[:, 0] @ t_hat)
    time = np.arange(1, n_steps + 1) * DT
    expected = G * (math.sin(theta) - mu * math.cos(theta))
    fitted = np.polyfit(time, speed_down, 1)[0]
    assert fitted == pytest.approx(expected, rel=0.01)
    assert speed_down[-1] == pytest.approx(expected * time[-1], rel=0.01)


@pytest.mark.parametrize("theta_deg", [20.0, 35.0])
def test_particle_sticks_on_an_incline_when_friction_allows(theta_deg):
    theta = math.radians(theta_deg)
    wall_xy, wall_friction = incline(theta, 1.1 * math.tan(theta))
    t_hat = np.array([math.cos(theta), math.sin(theta)])
    start = 50.0 * t_hat
    xs, vs, flags, _ = drop(start, [0.0, 0.0], wall_xy, wall_friction, 1000)
    assert np.all(flags[:, 0] == 1)
    assert np.all(np.abs(vs[:, 0] @ t_hat) < 1e-12)  # tangential velocity stays 0
    assert np.linalg.norm(xs[-1, 0] - start) < 1e-9


def test_particle_moving_parallel_to_the_wall_is_untouched():
    floor, mu = walls((-10.0, 0.0, 10.0, 0.0), mu=0.5)
    for y in (0.1, 0.0):  # above the floor, and sliding on it with no normal velocity
        xy = np.array([[0.0, y]])
        v = np.array([[3.0, 0.0]])
        contact, n = step(xy, v, floor, mu, gravity=(0.0, 0.0))
        assert n == 0 and contact[0] == 0
        assert v[0, 0] == 3.0 and v[0, 1] == 0.0


def test_particle_beyond_the_end_of_the_segment_falls_past_it():
    floor, mu = walls((-1.0, 0.0, 1.0, 0.0))
    xs, _, flags, _ = drop([[1.5, 0.2], [-1.5, 0.2], [0.0, 0.2]], np.zeros((3, 2)), floor, mu, 600)
    assert np.all(flags[:, :2] == 0)
    assert xs[-1, 0, 1] < -1.0 and xs[-1, 1, 1] < -1.0  # both fell past the ends
    assert abs(xs[-1, 2, 1]) < 1e-12  # the one above the segment rests on it


def test_segment_end_tolerance_is_a_tenth_of_the_reach():
    floor, mu = walls((-1.0, 0.0, 1.0, 0.0))
    for x, caught in ((1.0 + 0.09 * REACH, True), (1.0 + 0.11 * REACH, False), (-1.0 - 0.09 * REACH, True),
                      (-1.0 - 0.11 * REACH, False)):
        vx, vy, dvn = wall_contact_velocity(x, 0.001, 0.0, -2.0, DT, floor, mu, REACH)
        assert (dvn > 0.0) == caught
        assert vy == (pytest.approx(-1.0) if caught else -2.0)


def test_particle_far_behind_a_wall_is_ignored_and_one_within_reach_is_pushed_out():
    floor, mu = walls((-10.0, 0.0, 10.0, 0.0), mu=0.4)
    vx, vy, dvn = wall_contact_velocity(0.0, -1.5 * REACH, 0.5, 1.0, DT, floor, mu, REACH)
    assert (vx, vy, dvn) == (0.5, 1.0, 0.0)
    # within the wall's thickness: pushed out so it lands on the surface after the step
    gap = -0.5 * REACH
    vx, vy, dvn = wall_contact_velocity(0.0, gap, 0.0, -1.0, DT, floor, mu, REACH)
    assert vy == pytest.approx(-gap / DT)
    assert 0.0 + gap + DT * vy == pytest.approx(0.0, abs=1e-15)
    assert dvn == pytest.approx(-gap / DT + 1.0)


def test_corner_of_a_container_holds_a_particle_thrown_into_it():
    # floor then right wall, counter-clockwise around the material (inside: x < 1, y > 0)
    wall_xy, mu = walls((-1.0, 0.0, 1.0, 0.0), (1.0, 0.0, 1.0, 1.0), mu=0.2)
    xs, vs, flags, _ = drop([0.5, 0.3], [4.0, -1.0], wall_xy, mu, 1500)
    assert xs[:, 0, 1].min() >= -1e-12
    assert xs[:, 0, 0].max() <= 1.0 + 1e-12
    np.testing.assert_allclose(xs[-1, 0], [1.0, 0.0], atol=1e-9)  # came to rest in the corner
    assert np.all(np.abs(vs[-1, 0]) < 1e-9)


def test_no_walls_returns_zero_and_changes_nothing():
    xy = np.array([[0.0, -1.0], [0.3, 0.2]])
    v = np.array([[1.0, -2.0], [0.0, 5.0]])
    wall_xy, mu = np.zeros((0, 4)), np.zeros(0)
    contact, n = step(xy, v, wall_xy, mu, gravity=(0.0, 0.0))
    assert n == 0
    np.testing.assert_array_equal(v, [[1.0, -2.0], [0.0, 5.0]])
    np.testing.assert_array_equal(contact, [0, 0])
    assert wall_contact_velocity(0.0, -0.01, 1.0, -2.0, DT, wall_xy, mu, REACH) == (1.0, -2.0, 0.0)


def test_particles_with_a_fixed_direction_are_untouched():
    floor, mu = walls((-10.0, 0.0, 10.0, 0.0), mu=0.5)
    xy = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [3.0, 0.0]])
    v = np.array([[1.0, -2.0], [1.0, -2.0], [1.0, -2.0], [1.0, -2.0]])
    fixed = np.array([[True, False], [False, True], [True, True], [False, False]])
    contact, n = step(xy, v, floor, mu, fixed=fixed, gravity=(0.0, 0.0))
    assert n == 1
    np.testing.assert_array_equal(contact, [0, 0, 0, 1])
    np.testing.assert_array_equal(v[:3], [[1.0, -2.0]] * 3)
    assert v[3, 1] == 0.0 and v[3, 0] == 0.0  # dv_n = 2 and mu dv_n = 1 >= |v_t|: sticks


# warm up the compiled kernel before hypothesis times anything
wall_contact_velocity(0.0, 0.0, 0.0, -1.0, DT, *walls((-1.0, 0.0, 1.0, 0.0)), REACH)


@settings(deadline=None, max_examples=300)
@given(
    angle=st.floats(-math.pi, math.pi),
    length=st.floats(0.1, 20.0),
    along=st.floats(0.0, 1.0),
    gap_over_reach=st.floats(-0.999, 2.0),  # at exactly -reach round-off decides
    speed=st.floats(0.0, 50.0),
    direction=st.floats(-math.pi, math.pi),
    mu=st.floats(0.0, 2.0),
    dt=st.floats(1e-5, 1e-2),
)
def test_friction_never_reverses_and_the_particle_never_ends_inside(
    angle, length, along, gap_over_reach, speed, direction, mu, dt
):
    t_hat = np.array([math.cos(angle), math.sin(angle)])
    n_hat = np.array([-t_hat[1], t_hat[0]])
    p1 = np.array([0.3, -0.7])
    p2 = p1 + length * t_hat
    gap = gap_over_reach * REACH
    p = p1 + along * length * t_hat + gap * n_hat
    v = speed * np.array([math.cos(direction), math.sin(direction)])
    wall_xy = np.array([[p1[0], p1[1], p2[0], p2[1]]])
    vx, vy, dvn = wall_contact_velocity(p[0], p[1], v[0], v[1], dt, wall_xy, np.array([mu]), REACH)
    v_new = np.array([vx, vy])
    vt_old, vt_new = v @ t_hat, v_new @ t_hat
    vn_old, vn_new = v @ n_hat, v_new @ n_hat
    tol = 1e-9 * (1.0 + speed)
    assert dvn >= 0.0
    assert abs(vt_new) <= abs(vt_old) + tol  # friction only removes tangential speed
    assert vt_new * math.copysign(1.0, vt_old) >= -tol  # never reverses it (0 up to round-off)
    assert abs(vt_old - vt_new) <= mu * dvn + tol  # Coulomb cap
    # the end-of-step gap is never negative (up to round-off): the particle lands on or above it
    gap_here = (p - p1) @ n_hat
    assert gap_here + dt * vn_new >= -1e-9 * (REACH + abs(gap_here))
    # away from the round-off band around a zero predicted gap, the wall acts exactly when the
    # predicted gap is negative, and then the particle lands on the wall
    predicted = gap_here + dt * vn_old
    band = 1e-12 * (1.0 + abs(gap_here) + dt * speed)
    if predicted < -band:
        assert dvn > 0.0 and vn_new == pytest.approx(-gap_here / dt, rel=1e-9, abs=1e-9)
    elif predicted > band:
        assert dvn == 0.0 and (vx, vy) == (v[0], v[1])
