"""Stress update of every particle: objective (Jaumann) rotation, then its material's law.

Plane strain, tension positive, stress stored as (xx, yy, zz, xy).  With the smoothed
velocity gradient L over a step dt:

    d = sym(L) dt,   w = skew(L) dt,   omega = w_xy = (L_xy - L_yx) dt / 2
    Jaumann:  sigma += w sigma - sigma w
              s_xx += 2 omega s_xy,  s_yy -= 2 omega s_xy,  s_xy += omega (s_yy - s_xx)
    elastic:  sigma += lambda tr(d) I + 2 G d      (``materials.elastic``)
    plastic:  the elastic trial and return map of the row's model (``materials.<model>``), then
              the tension cut-off where the row's tensile strength is finite: the one dispatch
              on the model code, in :func:`update_stress_range`

A model code without a branch there (a model registered in ``materials.MODELS`` and not here)
stops the update with a ValueError naming the code, raised outside the threads (an exception
raised on a numba thread is lost), instead of running another model's return map.

Particle k reads row ``material_row[k]`` of the material arrays (``materials.table``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange

from spfem_core.jit import chunk_bounds, inner_kernel, kernel, n_chunks, parallel_inner_kernel
from spfem_core.materials import drucker_prager, elastic, mohr_coulomb, tresca
from spfem_core.materials.drucker_prager import drucker_prager_update
from spfem_core.materials.elastic import elastic_increment
from spfem_core.materials.mohr_coulomb import mohr_coulomb_update, softened_strength
from spfem_core.materials.tension_cutoff import tension_cutoff
from spfem_core.materials.tresca import tresca_update
from spfem_core.state import L_XX, L_XY, L_YX, L_YY, XX, XY, YY

NO_UNREGISTERED_MODEL = -1
"""What :func:`update_stress_range` reports when every row it met had its model's branch."""


@kernel
def rotate_jaumann(stress, k, lxy, lyx, dt):
    """Objective rotation of particle k's stress by the spin of L over dt (see module doc)."""
    omega = 0.5 * (lxy - lyx) * dt
    sxx = stress[k, XX]
    syy = stress[k, YY]
    sxy = stress[k, XY]
    stress[k, XX] = sxx + 2.0 * omega * sxy
    stress[k, YY] = syy - 2.0 * omega * sxy
    stress[k, XY] = sxy + omega * (syy - sxx)


@inner_kernel
def update_stress(
    node_L, node_area, node_stress, node_plastic_strain, node_material_row, mat_model, mat_lambda, mat_shear,
    mat_params, dt, n_threads,
):
    """Rotate and update every particle's stress from its smoothed velocity gradient.

    Elastic rows take the Hooke increment, the others the elastic trial and return map of their
    model.  Adds the equivalent plastic strain increment to ``node_plastic_strain`` and returns
    the plastic work of the step, sum_k A_k sigma:d_eps_p (J/m), summed in fixed chunks of
    particles (``jit`` module doc); on threads unless ``n_threads`` is None (``jit.kernel_threads``).
    A ValueError when a row's model code has no branch in :func:`update_stress_range`.
    """
    n_node = node_stress.shape[0]
    n_chunk = n_chunks(n_node)
    chunk_work = np.zeros(n_chunk)
    unregistered = NO_UNREGISTERED_MODEL
    if n_threads is not None:  # decided when compiling (jit.kernel_threads)
        chunk_unregistered = np.empty(n_chunk, dtype=np.int64)
        update_stress_threaded(node_L, node_area, node_stress, node_plastic_strain, node_material_row, mat_model,
                               mat_lambda, mat_shear, mat_params, dt, chunk_work, chunk_unregistered)
        for chunk in range(n_chunk):
            if unregistered == NO_UNREGISTERED_MODEL:
                unregistered = chunk_unregistered[chunk]
    else:  # the same chunks, and no array for the codes
        for chunk in range(n_chunk):
            start, end = chunk_bounds(chunk, n_node)
            chunk_work[chunk], code = update_stress_range(
                node_L, node_area, node_stress, node_plastic_strain, node_material_row, mat_model, mat_lambda,
                mat_shear, mat_params, dt, start, end)
            if unregistered == NO_UNREGISTERED_MODEL:
                unregistered = code
    if unregistered != NO_UNREGISTERED_MODEL:
        raise ValueError("constitutive.update_stress_range has no branch for the material model of code",
                         unregistered)
    plastic_work = 0.0
    for chunk in range(n_chunk):  # a loop of its own: the sum compiles as it always has (the same bits)
        plastic_work += chunk_work[chunk]
    return plastic_work


@parallel_inner_kernel
def update_stress_threaded(node_L, node_area, node_stress, node_plastic_strain, node_material_row, mat_model,
                           mat_lambda, mat_shear, mat_params, dt, chunk_work, chunk_unregistered):
    """:func:`update_stress_range` of every chunk of particles on threads, its work in ``chunk_work``
    and any unregistered model code in ``chunk_unregistered``."""
    n_node = node_stress.shape[0]
    for chunk in prange(chunk_work.shape[0]):
        start, end = chunk_bounds(chunk, n_node)
        chunk_work[chunk], chunk_unregistered[chunk] = update_stress_range(
            node_L, node_area, node_stress, node_plastic_strain, node_material_row, mat_model, mat_lambda, mat_shear,
            mat_params, dt, start, end)


@inner_kernel
def update_stress_range(
    node_L, node_area, node_stress, node_plastic_strain, node_material_row, mat_model, mat_lambda, mat_shear,
    mat_params, dt, start, end,
):
    """:func:`update_stress` of particles start..end-1: (their plastic work in J/m,
    :data:`NO_UNREGISTERED_MODEL` or the code of a row's model that has no branch here, where the
    update stopped)."""
    plastic_work = 0.0
    for k in range(np.uint64(start), np.uint64(end)):  # unsigned: no negative-index wraparound code
        area = node_area[k]
        if area <= 0.0:
            continue  # a particle in no triangle carries its stress unchanged
        lxx = node_L[k, L_XX]
        lxy = node_L[k, L_XY]
        lyx = node_L[k, L_YX]
        lyy = node_L[k, L_YY]
        rotate_jaumann(node_stress, k, lxy, lyx, dt)
        row = np.uint64(node_material_row[k])  # unsigned: no negative-index wraparound code
        dxx = lxx * dt
        dyy = lyy * dt
        dxy = 0.5 * (lxy + lyx) * dt
        model = mat_model[row]
        if model == elastic.CODE:
            elastic_increment(node_stress, k, dxx, dyy, dxy, mat_lambda[row], mat_shear[row])
            continue
        lame_lambda = mat_lambda[row]
        shear_modulus = mat_shear[row]
        if model == drucker_prager.CODE:
            d_eq, work = drucker_prager_update(
                node_stress, k, dxx, dyy, dxy, lame_lambda, shear_modulus, mat_params[row, drucker_prager.ALPHA],
                mat_params[row, drucker_prager.K], mat_params[row, drucker_prager.ALPHA_PSI])
            tensile_strength = mat_params[row, drucker_prager.TENSILE_STRENGTH]
        elif model == mohr_coulomb.CODE:
            if mat_params[row, mohr_coulomb.SOFTENING_LAW] == mohr_coulomb.SOFTENING_NONE:
                d_eq, work = mohr_coulomb_update(
                    node_stress, k, dxx, dyy, dxy, lame_lambda, shear_modulus, mat_params[row, mohr_coulomb.COHESION],
                    mat_params[row, mohr_coulomb.SIN_PHI], mat_params[row, mohr_coulomb.COS_PHI],
                    mat_params[row, mohr_coulomb.SIN_PSI])
            else:
                cohesion, sin_phi, cos_phi, sin_psi = softened_strength(mat_params, row, node_plastic_strain[k])
                d_eq, work = mohr_coulomb_update(node_stress, k, dxx, dyy, dxy, lame_lambda, shear_modulus, cohesion,
                                                 sin_phi, cos_phi, sin_psi)
            tensile_strength = mat_params[row, mohr_coulomb.TENSILE_STRENGTH]
        elif model == tresca.CODE:
            d_eq, work = tresca_update(node_stress, k, dxx, dyy, dxy, lame_lambda, shear_modulus,
                                       mat_params[row, tresca.UNDRAINED_SHEAR_STRENGTH])
            tensile_strength = mat_params[row, tresca.TENSILE_STRENGTH]
        else:  # a model of materials.MODELS without its branch: update_stress raises
            return plastic_work, model
        if tensile_strength < math.inf:
            d_eq_t, work_t = tension_cutoff(node_stress, k, model == drucker_prager.CODE, tensile_strength,
                                            lame_lambda, shear_modulus)
            d_eq += d_eq_t
            work += work_t
        node_plastic_strain[k] += d_eq
        plastic_work += area * work
    return plastic_work, NO_UNREGISTERED_MODEL
