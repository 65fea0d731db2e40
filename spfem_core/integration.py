"""Leapfrog time integration with local (Cundall) damping and prescribed velocities.

For every particle and direction, with f = m g + f_int + f_stab (the unbalanced force):

    f_damp = -xi |f| sign(v^{n-1/2})        (sign(0) = 0)
    v^{n+1/2} = v^{n-1/2} + dt (f + f_damp) / m_i
    v^{n+1/2} = v_prescribed                 where the direction is fixed
    v^{n+1/2} corrected by the rigid walls (``contact``), only when there are walls
    along a slip support (below), before the damping: v_t = 0 if |v_t^free| <= dt C / m_i,
        else f_t -> f_t - C sign(v_t^free)                 (v_t^free = v_t^{n-1/2} + dt f_t / m_i)
    x^{n+1} = x^n + dt v^{n+1/2},  u^{n+1} = u^n + dt v^{n+1/2}

A slip support (``state.NodeState.slip``) prescribes one direction, the normal n, and resists
the other, the tangent t, with the soil's strength over the particle's share L_k of the support:

    C = c L_k + tan(phi) N,   N = max(s f_n, 0)       (s = +-1: the side the support lies on)

with f_n the particle's unbalanced normal force, the reaction the support gives.  A stuck particle
counts as fixed in the unbalanced-force sums; the resisting impulse's work is the contact loss.

Particle masses m are fixed at the start and never recomputed.  The inertia m_i is m, except in a
density-scaled relaxation of a graded cloud (``simulation.Simulation.relax``), where it is larger
for the finer particles; the weight is always m g.

A scene pays nothing for what it does not use: given no rows of inertia (an array of length 0, as
for no walls; ``stepper.advance`` passes none when ``state.StepParameters.inertia_is_mass`` says
so), the leapfrog runs :func:`leapfrog_range_plain`, which reads the masses as the inertia and no
slip row, over every particle but those on a slip support (``slip_nodes``, in increasing order), and
:func:`leapfrog_range` over each run of consecutive particles on one, the masses as their inertia:
the sums go on from one range to the next in the particles' order, and the steps are the same bits
as those of :func:`leapfrog_range` over every particle (a slope on its default rough base reads its
base's slip rows alone).
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange

from spfem_core.contact import wall_contact_velocity
from spfem_core.jit import chunk_bounds, inline_kernel, inner_kernel, kernel, n_chunks, parallel_inner_kernel
from spfem_core.state import (
    LEAPFROG_APPLIED_FORCE_SQ,
    LEAPFROG_CONTACT_LOSS,
    LEAPFROG_CONTACTS,
    LEAPFROG_DAMPING_POWER,
    LEAPFROG_MAX_SPEED_SQ,
    LEAPFROG_OUT_WIDTH,
    LEAPFROG_UNBALANCED_FORCE_SQ,
    SLIP_COHESION,
    SLIP_FRICTION,
    SLIP_SIDE,
)


@inner_kernel
def sign0(value):
    """sign with sign(0) = 0 (ESPFEM2D's +1 for zero over-amplifies the first step)."""
    if value > 0.0:
        return 1.0
    if value < 0.0:
        return -1.0
    return 0.0


@kernel
def leapfrog(
    node_xy, node_u, node_v, node_force, node_mass, node_inertia, node_fixed, node_fixed_v, node_slip, slip_nodes,
    gravity, damping, dt, wall_xy, wall_friction, reach, node_contact, out, n_threads,
):
    """Advance velocities and positions one step (module doc).

    ``node_force`` holds f_int + f_stab on entry; ``node_inertia`` without rows: the inertia is the mass,
    and ``node_slip`` is read only for the particles of ``slip_nodes`` (module doc).  Fills ``out`` with the slots of
    ``state.LEAPFROG_OUT`` (the largest speed squared, the unbalanced and applied forces squared,
    the damping power, the energy the walls removed, the particles touching a wall); the sums are
    taken in fixed chunks of particles (``jit``), on threads unless ``n_threads`` is None
    (``jit.kernel_threads``).

    The walls' share is minus the work of their impulse m (w - v) at the mid-step velocity
    (v^{n-1/2} + w) / 2, the measure of a leapfrog step's kinetic energy change
    (sum m dv . (v^{n-1/2} + v^{n+1/2}) / 2); the damping power is taken at v^{n-1/2}.  Measuring it as
    m (v^2 - w^2) / 2 instead counted m (dt f / m)^2 / 2 every step for a particle at rest
    on a floor, a loss proportional to dt that never happened.
    """
    n_node = node_xy.shape[0]
    if node_inertia.shape[0] != 0 and node_slip.shape[0] == 0:
        raise ValueError("leapfrog: the inertia rows are given with the slip rows")
    n_chunk = n_chunks(n_node)
    chunk_out = np.zeros((n_chunk, LEAPFROG_OUT_WIDTH))
    if n_threads is not None:  # decided when compiling (jit.kernel_threads)
        leapfrog_threaded(node_xy, node_u, node_v, node_force, node_mass, node_inertia, node_fixed, node_fixed_v,
                          node_slip, slip_nodes, gravity, damping, dt, wall_xy, wall_friction, reach, node_contact,
                          chunk_out)
    else:  # the same chunks
        for chunk in range(n_chunk):
            start, end = chunk_bounds(chunk, n_node)
            leapfrog_chunk(node_xy, node_u, node_v, node_force, node_mass, node_inertia, node_fixed, node_fixed_v,
                           node_slip, slip_nodes, gravity, damping, dt, wall_xy, wall_friction, reach, node_contact,
                           start, end, chunk_out[chunk])
    out[:] = 0.0
    for chunk in range(n_chunk):
        fastest = chunk_out[chunk, LEAPFROG_MAX_SPEED_SQ]
        out[LEAPFROG_MAX_SPEED_SQ] = larger_or_nan(out[LEAPFROG_MAX_SPEED_SQ], fastest)
        for c in range(LEAPFROG_MAX_SPEED_SQ + 1, LEAPFROG_OUT_WIDTH):  # the sums
            out[c] += chunk_out[chunk, c]


@parallel_inner_kernel
def leapfrog_threaded(node_xy, node_u, node_v, node_force, node_mass, node_inertia, node_fixed, node_fixed_v, node_slip,
                      slip_nodes, gravity, damping, dt, wall_xy, wall_friction, reach, node_contact, chunk_out):
    """:func:`leapfrog_chunk` of every chunk of particles on threads, the sums in ``chunk_out`` (kept
    apart: a function with a parallel loop costs about 3 us a call even when it runs no thread)."""
    n_node = node_xy.shape[0]
    for chunk in prange(chunk_out.shape[0]):
        start, end = chunk_bounds(chunk, n_node)
        leapfrog_chunk(node_xy, node_u, node_v, node_force, node_mass, node_inertia, node_fixed, node_fixed_v,
                       node_slip, slip_nodes, gravity, damping, dt, wall_xy, wall_friction, reach, node_contact,
                       start, end, chunk_out[chunk])


@inner_kernel
def leapfrog_chunk(node_xy, node_u, node_v, node_force, node_mass, node_inertia, node_fixed, node_fixed_v, node_slip,
                   slip_nodes, gravity, damping, dt, wall_xy, wall_friction, reach, node_contact, start, end, out):
    """Particles start..end-1, their sums in ``out`` (zero on entry): :func:`leapfrog_range` given the
    inertia rows; else :func:`leapfrog_range_plain` between the runs of consecutive particles of
    ``slip_nodes`` and :func:`leapfrog_range` over each run, the masses as their inertia (module doc)."""
    if node_inertia.shape[0] != 0:
        leapfrog_range(node_xy, node_u, node_v, node_force, node_mass, node_inertia, node_fixed, node_fixed_v,
                       node_slip, gravity, damping, dt, wall_xy, wall_friction, reach, node_contact, start, end, out)
        return
    n_slip = slip_nodes.shape[0]
    i = np.searchsorted(slip_nodes, start)
    done = start
    while i < n_slip and slip_nodes[i] < end:
        first = slip_nodes[i]
        last = first + 1  # one past the run
        i += 1
        while i < n_slip and slip_nodes[i] == last and last < end:
            last += 1
            i += 1
        if first > done:
            leapfrog_range_plain(node_xy, node_u, node_v, node_force, node_mass, node_fixed, node_fixed_v, gravity,
                                 damping, dt, wall_xy, wall_friction, reach, node_contact, done, first, out)
        leapfrog_range(node_xy, node_u, node_v, node_force, node_mass, node_mass, node_fixed, node_fixed_v,
                       node_slip, gravity, damping, dt, wall_xy, wall_friction, reach, node_contact, first, last, out)
        done = last
    if done < end:
        leapfrog_range_plain(node_xy, node_u, node_v, node_force, node_mass, node_fixed, node_fixed_v, gravity,
                             damping, dt, wall_xy, wall_friction, reach, node_contact, done, end, out)


@inner_kernel
def leapfrog_range(node_xy, node_u, node_v, node_force, node_mass, node_inertia, node_fixed, node_fixed_v, node_slip, gravity,
                   damping, dt, wall_xy, wall_friction, reach, node_contact, start, end, out):
    """:func:`leapfrog` of particles start..end-1, their sums added to those in ``out`` (its layout)."""
    use_walls = wall_xy.shape[0] > 0
    max_speed_sq = out[LEAPFROG_MAX_SPEED_SQ]  # the sums so far (module doc)
    unbalanced_sq = out[LEAPFROG_UNBALANCED_FORCE_SQ]
    applied_sq = out[LEAPFROG_APPLIED_FORCE_SQ]
    damping_power = out[LEAPFROG_DAMPING_POWER]
    contact_loss = out[LEAPFROG_CONTACT_LOSS]
    n_contact = out[LEAPFROG_CONTACTS]
    for k in range(np.uint64(start), np.uint64(end)):  # unsigned: no negative-index wraparound code
        m = node_inertia[k]
        v_start_x = node_v[k, 0]
        v_start_y = node_v[k, 1]
        slip_side = node_slip[k, SLIP_SIDE]
        for d in range(2):
            weight = node_mass[k] * gravity[d]
            f = node_force[k, d] + weight
            v_old = node_v[k, d]
            if node_fixed[k, d]:
                v_new = node_fixed_v[k, d]
            elif slip_side == 0.0:
                f_damp = 0.0
                if damping > 0.0:
                    f_damp = -damping * abs(f) * sign0(v_old)
                    damping_power += f_damp * v_old
                unbalanced_sq += f * f
                applied_sq += weight * weight
                v_new = v_old + dt * (f + f_damp) / m
            else:  # along a slip support: the soil's strength resists first
                f_normal = node_force[k, 1 - d] + node_mass[k] * gravity[1 - d]
                capacity = node_slip[k, SLIP_COHESION] + node_slip[k, SLIP_FRICTION] * max(slip_side * f_normal, 0.0)
                v_free = v_old + dt * f / m
                if abs(v_free) <= capacity * dt / m:  # stuck: the support holds it, as a fixed direction
                    contact_loss += 0.5 * m * v_free * v_old  # the stopping impulse's work at v_old / 2
                    node_v[k, d] = 0.0
                    continue
                resistance = -capacity * sign0(v_free)
                contact_loss -= resistance * dt * 0.5 * (v_old + v_free + dt * resistance / m)
                f += resistance  # the net force, which the damping then acts on
                f_damp = 0.0
                if damping > 0.0:
                    f_damp = -damping * abs(f) * sign0(v_old)
                    damping_power += f_damp * v_old
                unbalanced_sq += f * f
                applied_sq += weight * weight
                v_new = v_old + dt * (f + f_damp) / m
                if v_new * v_free < 0.0:  # the damping does not turn a slide back
                    v_new = 0.0
            node_v[k, d] = v_new
        vx = node_v[k, 0]
        vy = node_v[k, 1]
        if use_walls:
            node_contact[k] = 0
            if not (node_fixed[k, 0] or node_fixed[k, 1]):
                wx, wy, dvn = wall_contact_velocity(
                    node_xy[k, 0], node_xy[k, 1], vx, vy, dt, wall_xy, wall_friction, reach
                )
                if dvn != 0.0 or wx != vx or wy != vy:
                    # work of the wall's impulse m (w - v) over the step, at the leapfrog mid-step
                    # velocity (v^{n-1/2} + v^{n+1/2}) / 2: zero for a particle resting on it
                    contact_loss -= 0.5 * m * ((wx - vx) * (v_start_x + wx) + (wy - vy) * (v_start_y + wy))
                    node_contact[k] = 1
                    n_contact += 1
                    vx = wx
                    vy = wy
                    node_v[k, 0] = vx
                    node_v[k, 1] = vy
        node_xy[k, 0] += dt * vx
        node_xy[k, 1] += dt * vy
        node_u[k, 0] += dt * vx
        node_u[k, 1] += dt * vy
        max_speed_sq = larger_or_nan(max_speed_sq, vx * vx + vy * vy)
    out[LEAPFROG_MAX_SPEED_SQ] = max_speed_sq
    out[LEAPFROG_UNBALANCED_FORCE_SQ] = unbalanced_sq
    out[LEAPFROG_APPLIED_FORCE_SQ] = applied_sq
    out[LEAPFROG_DAMPING_POWER] = damping_power
    out[LEAPFROG_CONTACT_LOSS] = contact_loss
    out[LEAPFROG_CONTACTS] = n_contact


@inner_kernel
def leapfrog_range_plain(node_xy, node_u, node_v, node_force, node_mass, node_fixed, node_fixed_v, gravity, damping, dt,
                         wall_xy, wall_friction, reach, node_contact, start, end, out):
    """:func:`leapfrog_range` of particles on no slip support whose inertia is the mass: the same
    steps, without reading either (``tests/test_integration.py`` holds the two to the same bits).
    The free direction divides by the mass read where it divides, as :func:`leapfrog_range` divides
    by the inertia: with one mass for both directions numba's optimiser forms dt / m once per
    particle, which rounds differently."""
    use_walls = wall_xy.shape[0] > 0
    max_speed_sq = out[LEAPFROG_MAX_SPEED_SQ]  # the sums so far (module doc)
    unbalanced_sq = out[LEAPFROG_UNBALANCED_FORCE_SQ]
    applied_sq = out[LEAPFROG_APPLIED_FORCE_SQ]
    damping_power = out[LEAPFROG_DAMPING_POWER]
    contact_loss = out[LEAPFROG_CONTACT_LOSS]
    n_contact = out[LEAPFROG_CONTACTS]
    for k in range(np.uint64(start), np.uint64(end)):  # unsigned: no negative-index wraparound code
        m = node_mass[k]
        v_start_x = node_v[k, 0]
        v_start_y = node_v[k, 1]
        for d in range(2):
            weight = m * gravity[d]
            f = node_force[k, d] + weight
            v_old = node_v[k, d]
            if node_fixed[k, d]:
                v_new = node_fixed_v[k, d]
            else:
                f_damp = 0.0
                if damping > 0.0:
                    f_damp = -damping * abs(f) * sign0(v_old)
                    damping_power += f_damp * v_old
                unbalanced_sq += f * f
                applied_sq += weight * weight
                v_new = v_old + dt * (f + f_damp) / node_mass[k]
            node_v[k, d] = v_new
        vx = node_v[k, 0]
        vy = node_v[k, 1]
        if use_walls:
            node_contact[k] = 0
            if not (node_fixed[k, 0] or node_fixed[k, 1]):
                wx, wy, dvn = wall_contact_velocity(
                    node_xy[k, 0], node_xy[k, 1], vx, vy, dt, wall_xy, wall_friction, reach
                )
                if dvn != 0.0 or wx != vx or wy != vy:
                    contact_loss -= 0.5 * m * ((wx - vx) * (v_start_x + wx) + (wy - vy) * (v_start_y + wy))
                    node_contact[k] = 1
                    n_contact += 1
                    vx = wx
                    vy = wy
                    node_v[k, 0] = vx
                    node_v[k, 1] = vy
        node_xy[k, 0] += dt * vx
        node_xy[k, 1] += dt * vy
        node_u[k, 0] += dt * vx
        node_u[k, 1] += dt * vy
        max_speed_sq = larger_or_nan(max_speed_sq, vx * vx + vy * vy)
    out[LEAPFROG_MAX_SPEED_SQ] = max_speed_sq
    out[LEAPFROG_UNBALANCED_FORCE_SQ] = unbalanced_sq
    out[LEAPFROG_APPLIED_FORCE_SQ] = applied_sq
    out[LEAPFROG_DAMPING_POWER] = damping_power
    out[LEAPFROG_CONTACT_LOSS] = contact_loss
    out[LEAPFROG_CONTACTS] = n_contact


@inline_kernel
def larger_or_nan(largest, value):
    """max(largest, value), NaN once either is NaN (an inf stays too)."""
    if largest != largest or value != value:
        return math.nan
    return value if value > largest else largest
