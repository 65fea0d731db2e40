"""The compiled time loop: many explicit steps per call, no Python per step.

One step (method notes, section 1), all on the current mesh:
  1. element geometry and smoothed velocity gradients L_k     (smoothing.smooth_velocity_gradient)
  2. Jaumann rotation + constitutive update of every particle (constitutive.update_stress)
  3. internal force f_I = sum_e A_e B_I^e^T sigma_bar_e       (smoothing.add_internal_force)
  4. rank-deficiency bond forces, only when beta > 0          (stabilisation.add_stabilisation_force)
  5. leapfrog with local damping, prescribed velocities and   (integration.leapfrog)
     rigid walls (only when the scene has walls)              (contact.wall_contact_velocity)

The loop returns to Python only when it has done the steps asked, when the record buffers
are full, when the mesh needs rebuilding (an inverted element, or a smallest angle below the
threshold: measured exactly only when a cheap strain-rate bound on the angle change has used
up its budget), when a relaxation has converged, or on divergence.
"""

from __future__ import annotations

import math

import numpy as np

from spfem_core.constitutive import elastic_energy_density, update_stress
from spfem_core.integration import leapfrog
from spfem_core.jit import kernel
from spfem_core.mesh import element_quality_min_angle
from spfem_core.smoothing import add_internal_force, smooth_velocity_gradient
from spfem_core.stabilisation import add_stabilisation_force

STATUS_DONE = 0
STATUS_MESH_CHECK = 1  # the angle bound used its budget: Python checks the mesh, then goes on
STATUS_INVERTED = 2  # an element turned inside out before the step: rebuild the mesh
STATUS_NOT_FINITE = 3
STATUS_RUNAWAY = 4  # a particle faster than the P-wave speed
STATUS_CONVERGED = 5  # unbalanced-force ratio below the tolerance (relaxation)
STATUS_BUFFER_FULL = 6

ENERGY_COLUMNS = (
    "kinetic",
    "strain",
    "gravity_potential",
    "damping_dissipated",
    "stabilisation_dissipated",
    "plastic_dissipated",
    "contact_dissipated",
)
"""Columns of the recorded energy array (J per metre of out-of-plane thickness)."""

# accumulator slots carried across calls
ACC_DAMPING_WORK = 0  # energy removed by local damping (J/m, >= 0)
ACC_STAB_WORK = 1  # energy removed by the stabilisation (J/m, >= 0)
ACC_ANGLE_USED = 2  # bound on how much any element angle has changed since the last check (rad)
ACC_LAST_RATIO = 3  # unbalanced-force ratio at the last step
ACC_LAST_MAX_SPEED = 4  # max particle speed at the last step (m/s)
ACC_NEXT_RECORD = 5  # stage time of the next record (s)
ACC_PLASTIC_WORK = 6  # energy dissipated by plastic flow (J/m, >= 0)
ACC_CONTACT_WORK = 7  # kinetic energy removed by the walls (J/m, >= 0)
ACC_CONTACTS = 8  # particles touching a wall at the last step
ACC_MESH_CHECKS = 9  # exact quality checks done inside the loop
ACC_ANGLE_BUDGET = 10  # how much the smallest angle may change before the next exact check (rad)
ACC_WIDTH = 11

STEP_OUT_WIDTH = 6
"""Length of the per-step scratch array filled by ``integration.leapfrog``."""


@kernel
def record_state(
    slot, time_s, node_u, node_v, node_stress, node_mass, node_area, node_material, mat_youngs, mat_poisson,
    gravity, monitor_nodes, acc, rec_time, rec_u, rec_v, rec_stress, rec_energy, rec_max_u,
):
    """Write monitors, energies and the max displacement into row ``slot`` of the buffers."""
    rec_time[slot] = time_s
    for m in range(monitor_nodes.shape[0]):
        k = monitor_nodes[m]
        for d in range(2):
            rec_u[slot, m, d] = node_u[k, d]
            rec_v[slot, m, d] = node_v[k, d]
        for c in range(4):
            rec_stress[slot, m, c] = node_stress[k, c]
    kinetic = 0.0
    strain = 0.0
    potential = 0.0
    max_u_sq = 0.0
    for k in range(node_u.shape[0]):
        mass = node_mass[k]
        vx = node_v[k, 0]
        vy = node_v[k, 1]
        ux = node_u[k, 0]
        uy = node_u[k, 1]
        kinetic += 0.5 * mass * (vx * vx + vy * vy)
        potential -= mass * (gravity[0] * ux + gravity[1] * uy)
        mat = node_material[k]
        strain += node_area[k] * elastic_energy_density(
            node_stress[k, 0], node_stress[k, 1], node_stress[k, 2], node_stress[k, 3], mat_youngs[mat], mat_poisson[mat]
        )
        u_sq = ux * ux + uy * uy
        if u_sq > max_u_sq:
            max_u_sq = u_sq
    rec_energy[slot, 0] = kinetic
    rec_energy[slot, 1] = strain
    rec_energy[slot, 2] = potential
    rec_energy[slot, 3] = acc[ACC_DAMPING_WORK]
    rec_energy[slot, 4] = acc[ACC_STAB_WORK]
    rec_energy[slot, 5] = acc[ACC_PLASTIC_WORK]
    rec_energy[slot, 6] = acc[ACC_CONTACT_WORK]
    rec_max_u[slot] = math.sqrt(max_u_sq)


@kernel
def advance(
    # particle state (updated in place)
    node_xy, node_u, node_v, node_stress, node_plastic_strain, node_mass, node_material, node_fixed, node_fixed_v,
    # work arrays
    node_L, node_area, node_force, elem_geom, step_out, node_contact,
    # mesh
    elem_nodes, edge_nodes,
    # materials
    mat_model, mat_lambda, mat_shear, mat_youngs, mat_poisson, mat_params,
    # rigid walls; wall_reach is the particle spacing h (also bounds short stabilisation bonds)
    wall_xy, wall_friction, wall_reach,
    # parameters
    gravity, dt, damping, beta, speed_limit, tolerance, angle_threshold, angle_margin,
    # stepping: number of steps to do, stage time at the start of this call (s)
    n_steps, time_start,
    # records: one row every record_interval seconds of stage time
    record_interval, monitor_nodes, rec_count, rec_time, rec_u, rec_v, rec_stress, rec_energy, rec_max_u,
    # accumulators (ACC_*)
    acc,
):
    """Run up to ``n_steps`` steps; return (status, steps done). See the module doc."""
    n_rec_capacity = rec_time.shape[0]
    use_stabilisation = beta > 0.0
    speed_limit_sq = speed_limit * speed_limit
    half_dt = 0.5 * dt
    for s in range(n_steps):
        n_inverted, max_rate_sq = smooth_velocity_gradient(node_xy, node_v, elem_nodes, elem_geom, node_L, node_area)
        if n_inverted > 0:
            return STATUS_INVERTED, s
        acc[ACC_PLASTIC_WORK] += update_stress(
            node_L, node_area, node_stress, node_plastic_strain, node_material, mat_model, mat_lambda, mat_shear,
            mat_params, dt,
        )
        node_force[:, :] = 0.0
        add_internal_force(elem_nodes, elem_geom, node_stress, node_force)
        if use_stabilisation:
            stab_power = add_stabilisation_force(
                node_xy, node_v, node_L, node_area, node_material, mat_youngs, edge_nodes, beta, dt,
                0.25 * wall_reach * wall_reach, node_force,
            )
            acc[ACC_STAB_WORK] -= stab_power * dt
        leapfrog(
            node_xy, node_u, node_v, node_force, node_mass, node_fixed, node_fixed_v, gravity, damping, dt,
            wall_xy, wall_friction, wall_reach, node_contact, step_out,
        )
        acc[ACC_DAMPING_WORK] -= step_out[3] * dt
        acc[ACC_CONTACT_WORK] += step_out[4]
        acc[ACC_CONTACTS] = step_out[5]
        max_speed_sq = step_out[0]
        acc[ACC_LAST_MAX_SPEED] = math.sqrt(max_speed_sq) if max_speed_sq >= 0.0 else max_speed_sq
        if not (max_speed_sq <= speed_limit_sq):
            if max_speed_sq != max_speed_sq or max_speed_sq == math.inf:
                return STATUS_NOT_FINITE, s + 1
            return STATUS_RUNAWAY, s + 1
        ratio = math.sqrt(step_out[1] / step_out[2]) if step_out[2] > 0.0 else 0.0
        acc[ACC_LAST_RATIO] = ratio
        time_now = time_start + (s + 1) * dt
        if time_now >= acc[ACC_NEXT_RECORD] - half_dt:
            acc[ACC_NEXT_RECORD] += record_interval
            slot = rec_count[0]
            record_state(
                slot, time_now, node_u, node_v, node_stress, node_mass, node_area, node_material,
                mat_youngs, mat_poisson, gravity, monitor_nodes, acc, rec_time, rec_u, rec_v, rec_stress,
                rec_energy, rec_max_u,
            )
            rec_count[0] = slot + 1
            if rec_count[0] >= n_rec_capacity:
                return STATUS_BUFFER_FULL, s + 1
        acc[ACC_ANGLE_USED] += 2.0 * math.sqrt(max_rate_sq) * dt
        if acc[ACC_ANGLE_USED] >= acc[ACC_ANGLE_BUDGET]:
            # the cheap bound says the mesh may have degraded: measure it exactly, here
            acc[ACC_MESH_CHECKS] += 1.0
            min_angle = element_quality_min_angle(node_xy, elem_nodes)
            if not (min_angle >= angle_threshold):
                return STATUS_MESH_CHECK, s + 1
            acc[ACC_ANGLE_USED] = 0.0
            acc[ACC_ANGLE_BUDGET] = max(min_angle - angle_threshold - angle_margin, 0.0)
        if tolerance > 0.0 and ratio < tolerance:
            return STATUS_CONVERGED, s + 1
    return STATUS_DONE, n_steps


def empty_records(n_rec: int, n_monitor: int):
    """Record buffers for ``n_rec`` rows: (time, u, v, stress, energy, max_u)."""
    return (
        np.zeros(n_rec),
        np.zeros((n_rec, n_monitor, 2)),
        np.zeros((n_rec, n_monitor, 2)),
        np.zeros((n_rec, n_monitor, 4)),
        np.zeros((n_rec, len(ENERGY_COLUMNS))),
        np.zeros(n_rec),
    )
