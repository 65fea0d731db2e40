"""The compiled time loop: many explicit steps per call, no Python per step.

One step (method notes, section 1), all on the current mesh:
  1. smoothed velocity gradients L_k and cell areas A_k        (smoothing.smooth_velocity_gradient)
  2. Jaumann rotation + constitutive update of every particle (constitutive.update_stress)
  3. internal force f_I = sum_e A_e B_I^e^T sigma_bar_e, and   (nodal_force.assemble_nodal_force)
  4. rank-deficiency bond forces, only when beta > 0, in one pass (stabilisation.bond_force)
     pore and ponded water, surface loads, only when the scene   (external_forces.add_external_forces)
     has them
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

from spfem_core.constitutive import update_stress
from spfem_core.energy_budget import (
    DISSIPATED_CONTACT,
    DISSIPATED_DAMPING,
    DISSIPATED_LOADS,
    DISSIPATED_PLASTIC,
    DISSIPATED_STABILISATION,
    DISSIPATION_COLUMNS,
)
from spfem_core.external_forces import add_external_forces, external_power
from spfem_core.integration import leapfrog
from spfem_core.jit import kernel
from spfem_core.mesh import element_quality_min_angle
from spfem_core.nodal_force import assemble_nodal_force
from spfem_core.records import record_state
from spfem_core.smoothing import smooth_velocity_gradient
from spfem_core.state import (
    LEAPFROG_APPLIED_FORCE_SQ,
    LEAPFROG_CONTACT_LOSS,
    LEAPFROG_CONTACTS,
    LEAPFROG_DAMPING_POWER,
    LEAPFROG_MAX_SPEED_SQ,
    LEAPFROG_UNBALANCED_FORCE_SQ,
    SLIP_SIDE,
)

STATUS_DONE = 0
STATUS_MESH_CHECK = 1  # the angle bound used its budget: Python checks the mesh, then goes on
STATUS_INVERTED = 2  # an element turned inside out before the step: rebuild the mesh
STATUS_NOT_FINITE = 3
STATUS_RUNAWAY = 4  # a particle faster than the P-wave speed
STATUS_CONVERGED = 5  # unbalanced-force ratio below the tolerance (relaxation)
STATUS_BUFFER_FULL = 6

# slots of the loop's bookkeeping array, carried across calls
LOOP_ANGLE_USED = 0  # bound on how much any element angle has changed since the last check (rad)
LOOP_ANGLE_BUDGET = 1  # how much the smallest angle may change before the next exact check (rad)
LOOP_MESH_CHECKS = 2  # exact quality checks done inside the loop
LOOP_LAST_RATIO = 3  # unbalanced-force ratio at the last step
LOOP_LAST_MAX_SPEED = 4  # max particle speed at the last step (m/s)
LOOP_NEXT_RECORD = 5  # stage time of the next record (s)
LOOP_CONTACTS = 6  # particles touching a wall at the last step
LOOP_WIDTH = 7


def new_accumulators() -> tuple[np.ndarray, np.ndarray]:
    """(dissipated energy per ``energy_budget.DISSIPATION_COLUMNS``, loop bookkeeping per ``LOOP_*``), zeroed."""
    return np.zeros(len(DISSIPATION_COLUMNS)), np.zeros(LOOP_WIDTH)


@kernel
def advance(nodes, scratch, mesh, materials, walls, loads, params, n_steps, time_start_s,
            record_interval_s, monitor_nodes, records, dissipated, loop):
    """Run up to ``n_steps`` steps from stage time ``time_start_s``; return (status, steps done).

    ``nodes`` (``state.NodeState``) and ``scratch`` (``state.StepScratch``) are updated in place
    on the mesh ``mesh`` (``state.MeshArrays``);
    ``materials``, ``walls``, ``loads``, ``params`` are ``state.MaterialArrays``, ``state.Walls``,
    ``state.ExternalLoads``, ``state.StepParameters``.  A row of ``records`` (``records.RecordBuffers``) is written every
    ``record_interval_s`` of stage time for the particles ``monitor_nodes``; ``dissipated`` and
    ``loop`` are the accumulators of :func:`new_accumulators`.  See the module doc for when it
    returns early.
    """
    elem_nodes = mesh.elem_nodes
    node_xy = nodes.xy_m
    node_v = nodes.velocity_m_s
    node_force = scratch.force_n
    step_out = scratch.leapfrog_out
    dt = params.dt_s
    beta = params.beta
    n_rec_capacity = records.time_s.shape[0]
    use_stabilisation = beta > 0.0
    speed_limit_sq = params.speed_limit_m_s * params.speed_limit_m_s
    half_dt = 0.5 * dt
    leapfrog_inertia = nodes.inertia_kg
    if params.inertia_is_mass:  # the leapfrog reads no inertia, and slip rows only on the slip supports
        leapfrog_inertia = nodes.inertia_kg[:0]
    slip_nodes = np.nonzero(nodes.slip[:, SLIP_SIDE])[0]
    for s in range(n_steps):
        n_inverted, max_rate_sq = smooth_velocity_gradient(
            node_xy, node_v, elem_nodes, mesh.elem_block_ptr, mesh.elem_colour_ptr, mesh.elem_colour_block,
            scratch.velocity_gradient, scratch.area_m2, params.n_threads
        )
        if n_inverted > 0:
            return STATUS_INVERTED, s
        dissipated[DISSIPATED_PLASTIC] += update_stress(
            scratch.velocity_gradient, scratch.area_m2, nodes.stress_pa, nodes.plastic_strain, nodes.material_row,
            materials.model, materials.lame_lambda_pa, materials.shear_modulus_pa, materials.params, dt,
            params.n_threads,
        )
        stab_power = assemble_nodal_force(
            node_xy, node_v, scratch.velocity_gradient, scratch.area_m2, nodes.stress_pa, nodes.material_row,
            materials.youngs_modulus_pa, elem_nodes, mesh.elem_block_ptr, mesh.elem_colour_ptr,
            mesh.elem_colour_block, mesh.edge_nodes, mesh.edge_block_ptr, mesh.edge_colour_ptr, mesh.edge_colour_block,
            beta, dt, 0.25 * params.spacing_m * params.spacing_m, node_force, params.n_threads,
        )
        if use_stabilisation:
            dissipated[DISSIPATED_STABILISATION] -= stab_power * dt
        if loads.active:
            add_external_forces(node_xy, nodes.displacement_m, elem_nodes, loads,
                                time_start_s + s * dt, scratch.pore_pressure_pa, scratch.external_force_n, node_force)
        leapfrog(
            node_xy, nodes.displacement_m, node_v, node_force, nodes.mass_kg, leapfrog_inertia, nodes.fixed,
            nodes.fixed_velocity_m_s, nodes.slip, slip_nodes,
            params.gravity_m_s2, params.damping, dt, walls.xy_m, walls.friction, params.spacing_m, scratch.contact,
            step_out, params.n_threads,
        )
        dissipated[DISSIPATED_DAMPING] -= step_out[LEAPFROG_DAMPING_POWER] * dt
        dissipated[DISSIPATED_CONTACT] += step_out[LEAPFROG_CONTACT_LOSS]
        if loads.active:
            dissipated[DISSIPATED_LOADS] -= external_power(node_v, scratch.external_force_n) * dt
        loop[LOOP_CONTACTS] = step_out[LEAPFROG_CONTACTS]
        max_speed_sq = step_out[LEAPFROG_MAX_SPEED_SQ]
        loop[LOOP_LAST_MAX_SPEED] = math.sqrt(max_speed_sq) if max_speed_sq >= 0.0 else max_speed_sq
        if not (max_speed_sq <= speed_limit_sq):
            if max_speed_sq != max_speed_sq or max_speed_sq == math.inf:
                return STATUS_NOT_FINITE, s + 1
            return STATUS_RUNAWAY, s + 1
        unbalanced_sq, applied_sq = step_out[LEAPFROG_UNBALANCED_FORCE_SQ], step_out[LEAPFROG_APPLIED_FORCE_SQ]
        ratio = math.sqrt(unbalanced_sq / applied_sq) if applied_sq > 0.0 else 0.0
        loop[LOOP_LAST_RATIO] = ratio
        time_now = time_start_s + (s + 1) * dt
        if time_now >= loop[LOOP_NEXT_RECORD] - half_dt:
            loop[LOOP_NEXT_RECORD] += record_interval_s
            slot = records.count[0]
            record_state(slot, time_now, nodes, scratch.area_m2, materials, params.gravity_m_s2, monitor_nodes,
                         dissipated, records)
            records.count[0] = slot + 1
            if records.count[0] >= n_rec_capacity:
                return STATUS_BUFFER_FULL, s + 1
        loop[LOOP_ANGLE_USED] += 2.0 * math.sqrt(max_rate_sq) * dt
        if loop[LOOP_ANGLE_USED] >= loop[LOOP_ANGLE_BUDGET]:
            # the cheap bound says the mesh may have degraded: measure it exactly, here
            loop[LOOP_MESH_CHECKS] += 1.0
            min_angle = element_quality_min_angle(node_xy, elem_nodes)
            if not (min_angle >= params.angle_threshold_rad):
                return STATUS_MESH_CHECK, s + 1
            loop[LOOP_ANGLE_USED] = 0.0
            loop[LOOP_ANGLE_BUDGET] = max(min_angle - params.angle_threshold_rad - params.angle_margin_rad, 0.0)
        if params.tolerance > 0.0 and ratio < params.tolerance and time_now >= loads.ramp_time_s:
            return STATUS_CONVERGED, s + 1  # (not while the loads are still growing)
    return STATUS_DONE, n_steps


@kernel
def unbalanced_force_at_rest(nodes, scratch, mesh, materials, loads, gravity, time_s, unbalanced):
    """Fill ``unbalanced`` (n, 2) with the force a step would see if the particles were at rest:
    f_int of the current stress at the current positions + water and surface loads at stage time
    ``time_s`` + m g (steps 1, 3 and 4 of the module doc, without the bonds, which vanish at rest).
    One thread: it runs once per relaxation (``elastic_solve``)."""
    smooth_velocity_gradient(nodes.xy_m, nodes.velocity_m_s, mesh.elem_nodes, mesh.elem_block_ptr,
                             mesh.elem_colour_ptr, mesh.elem_colour_block, scratch.velocity_gradient,
                             scratch.area_m2, None)
    assemble_nodal_force(nodes.xy_m, nodes.velocity_m_s, scratch.velocity_gradient, scratch.area_m2, nodes.stress_pa,
                         nodes.material_row, materials.youngs_modulus_pa, mesh.elem_nodes,
                         mesh.elem_block_ptr, mesh.elem_colour_ptr, mesh.elem_colour_block, mesh.edge_nodes,
                         mesh.edge_block_ptr, mesh.edge_colour_ptr, mesh.edge_colour_block, 0.0, 0.0, 0.0,
                         scratch.force_n, None)
    if loads.active:
        add_external_forces(nodes.xy_m, nodes.displacement_m, mesh.elem_nodes, loads, time_s,
                            scratch.pore_pressure_pa, scratch.external_force_n, scratch.force_n)
    for k in range(unbalanced.shape[0]):
        for d in range(2):
            unbalanced[k, d] = scratch.force_n[k, d] + nodes.mass_kg[k] * gravity[d]
