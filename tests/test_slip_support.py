"""Slip supports (``[[boundary]] slip = "soil"``): one direction held, the other resisted by the
soil's strength C = c L_k + tan(phi) N (``spfem_core.integration``), and what it does to the FOS of
an undrained slope whose mechanism reaches a firm base (docs/verification.md, "Fixed supports")."""

from __future__ import annotations

import numpy as np
import pytest

from spfem_core.integration import leapfrog
from spfem_core.state import LEAPFROG_CONTACT_LOSS, LEAPFROG_OUT_WIDTH, LEAPFROG_UNBALANCED_FORCE_SQ
from verification.least_circle import slope_least_circle

DT = 1e-3
MASS = 2.0


def slide(force_xy, cohesion_n, tan_friction=0.0, n_steps=100, damping=0.0, v0=0.0):
    """One particle on a base (vy held, the support below it: side -1) pushed by a constant
    ``force_xy``; (x velocity after each step, contact loss of each step, unbalanced force^2)."""
    xy, u = np.zeros((1, 2)), np.zeros((1, 2))
    v = np.array([[v0, 0.0]])
    fixed = np.array([[False, True]])
    slip = np.array([[cohesion_n, tan_friction, -1.0]])
    out = np.zeros(LEAPFROG_OUT_WIDTH)
    velocities, losses, unbalanced = [], [], []
    for _ in range(n_steps):
        force = np.array([force_xy], dtype=float)
        leapfrog(xy, u, v, force, np.full(1, MASS), np.full(1, MASS), fixed, np.zeros((1, 2)), slip,
                 np.zeros(1, dtype=np.int64), np.zeros(2), damping, DT, np.zeros((0, 4)), np.zeros(0), 0.1, np.zeros(1, dtype=np.int64), out, None)
        velocities.append(v[0, 0])
        losses.append(out[LEAPFROG_CONTACT_LOSS])
        unbalanced.append(out[LEAPFROG_UNBALANCED_FORCE_SQ])
    return np.array(velocities), np.array(losses), np.array(unbalanced), xy[0]


def test_a_particle_below_its_strength_stays_and_counts_as_held():
    v, losses, unbalanced, xy = slide((90.0, -10.0), cohesion_n=100.0)
    assert np.all(v == 0.0) and xy[0] == 0.0
    assert np.all(losses == 0.0) and np.all(unbalanced == 0.0)


def test_a_particle_above_its_strength_accelerates_by_the_excess_and_dissipates_c_times_the_slide():
    v, losses, unbalanced, xy = slide((130.0, 0.0), cohesion_n=100.0)
    steps = np.arange(1, v.size + 1)
    np.testing.assert_allclose(v, steps * DT * 30.0 / MASS, rtol=1e-12)  # a = (f - C) / m
    np.testing.assert_allclose(unbalanced, 30.0**2, rtol=1e-12)  # the net force is what is out of balance
    # the resistance's work: C times the distance, at each step's mid-step velocity
    assert losses.sum() == pytest.approx(100.0 * xy[0], rel=0.02)
    assert np.all(losses > 0.0)


def test_the_normal_reaction_adds_friction_only_in_compression():
    pressed, *_ = slide((130.0, -50.0), cohesion_n=100.0, tan_friction=0.5)  # C = 100 + 0.5 * 50 = 125
    np.testing.assert_allclose(pressed[-1], pressed.size * DT * 5.0 / MASS, rtol=1e-12)
    pulled, *_ = slide((130.0, +50.0), cohesion_n=100.0, tan_friction=0.5)  # pulled away: C = 100
    np.testing.assert_allclose(pulled[-1], pulled.size * DT * 30.0 / MASS, rtol=1e-12)
    reversed_push, *_ = slide((-130.0, -50.0), cohesion_n=100.0, tan_friction=0.5)
    np.testing.assert_allclose(reversed_push[-1], -reversed_push.size * DT * 5.0 / MASS, rtol=1e-12)


def test_a_slide_without_push_comes_to_rest_and_does_not_turn_back():
    for damping in (0.0, 0.7):
        v, losses, _, _ = slide((0.0, 0.0), cohesion_n=100.0, v0=1.0, damping=damping)
        stop = int(np.argmax(v == 0.0))
        assert stop > 0 and np.all(v[stop:] == 0.0) and np.all(v >= 0.0)
        if damping == 0.0:  # the kinetic energy is what the support took (no force does work: f = 0)
            assert losses.sum() == pytest.approx(0.5 * MASS * 1.0**2, rel=0.02)
        else:  # the damping acts on the net force, -C: it shares the energy and stops it sooner
            assert 0.0 < losses.sum() < 0.5 * MASS * 1.0**2


@pytest.mark.slow
@pytest.mark.parametrize("angle_deg, taylor_n", [(60.0, 0.191), (90.0, 0.261)])
def test_least_circle_reproduces_taylors_toe_circles(angle_deg, taylor_n):
    """The bound the slopes below are held against: Taylor's (1937) chart, read to 3 digits."""
    circle = slope_least_circle(5.0, angle_deg, 20e3, 20e3)
    assert 20e3 / (circle.fos * 20e3 * 5.0) == pytest.approx(taylor_n, rel=0.005)


def _phi0_fos(tmp_path, base: str) -> float:
    """FOS of the 5 m undrained slope of taylor_phi0.toml at 45 deg, h = H / 10, on its base at the
    toe written ``vx_m_s = vy_m_s = 0``, welded or rough (``verification.fixed_supports.study_text``)."""
    import xarray as xr

    from verification.fixed_supports import study_text
    from workflows.cases import RunOptions
    from workflows.study import parse_study
    from workflows.study_types import run_study

    run_study(parse_study(study_text(45.0, 0.5, base)), tmp_path, RunOptions(workers=2))
    with xr.open_dataset(tmp_path / "summary.nc") as ds:
        return float(ds["fos"])


def test_an_undrained_slope_on_a_rigid_base_meets_its_least_circle_where_welded_particles_stood_4pc_above(tmp_path):
    """The least circle touches the base: on welded particles the slip can only pass a row above it
    (+4.1% at H / 10, falling at first order); on the base as written, vx = vy = 0, which is rough by
    default, the soil slides along it at cu and the FOS lies at the bound."""
    bound = slope_least_circle(5.0, 45.0, 20e3, 20e3).fos  # 1.2153
    on_rough_base = _phi0_fos(tmp_path / "rough", "rough")
    on_welded_base = _phi0_fos(tmp_path / "welded", "welded")
    assert abs(on_rough_base / bound - 1.0) < 0.01
    assert on_welded_base / bound - 1.0 > 0.03


def test_a_base_held_in_both_directions_is_the_slope_forms_slip_base():
    """``vx_m_s = vy_m_s = 0`` on a horizontal line of particles: held vertically, sliding along at the
    soil's strength, particle for particle the support that ``slip = "soil"`` with ``vy_m_s = 0`` makes;
    ``slip = "welded"`` holds both directions."""
    from verification.fixed_supports import study_text
    from workflows.scene import build_scene
    from workflows.study import parse_study

    rough = build_scene(parse_study(study_text(45.0, 0.5, "rough")))
    form = build_scene(parse_study(study_text(45.0, 0.5, "rough").split("[[boundary]]")[0]))  # the slope form's
    welded = build_scene(parse_study(study_text(45.0, 0.5, "welded")))
    for name in ("node_fixed", "node_fixed_velocity_m_s", "node_slip_length_m", "node_slip_side"):
        np.testing.assert_array_equal(getattr(rough, name), getattr(form, name))
    base = welded.node_xy_m[:, 1] <= 1e-9
    assert welded.node_fixed[base].all() and not welded.node_slip_length_m.any()
    assert not rough.node_fixed[base & (rough.node_xy_m[:, 0] > 1e-9), 0].any()
