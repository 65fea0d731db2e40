"""Stress update of one particle: objective (Jaumann) rotation, then the material law.

Plane strain, tension positive, stress stored as (xx, yy, zz, xy).  With the smoothed
velocity gradient L over a step dt:

    d = sym(L) dt,   w = skew(L) dt,   omega = w_xy = (L_xy - L_yx) dt / 2
    Jaumann:  sigma += w sigma - sigma w
              s_xx += 2 omega s_xy,  s_yy -= 2 omega s_xy,  s_xy += omega (s_yy - s_xx)
    elastic:  sigma += lambda tr(d) I + 2 G d      (d_zz = 0, so s_zz += lambda tr(d))
    plastic:  elastic trial, then the return map of the material's model (``plasticity``) with the
              strength softened by the particle's plastic strain where the material softens
              (``softened_strength``), then the tension cut-off where it has a tensile strength
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange

from spfem_core.jit import chunk_bounds, inner_kernel, kernel, n_chunks, parallel_inner_kernel
from spfem_core.plasticity import drucker_prager_update, mohr_coulomb_update, tension_cutoff
from spfem_core.scene import MODEL_DRUCKER_PRAGER, MODEL_ELASTIC


@kernel
def rotate_jaumann(stress, k, lxy, lyx, dt):
    """Objective rotation of particle k's stress by the spin of L over dt (see module doc)."""
    omega = 0.5 * (lxy - lyx) * dt
    sxx = stress[k, 0]
    syy = stress[k, 1]
    sxy = stress[k, 3]
    stress[k, 0] = sxx + 2.0 * omega * sxy
    stress[k, 1] = syy - 2.0 * omega * sxy
    stress[k, 3] = sxy + omega * (syy - sxx)


@kernel
def elastic_increment(stress, k, dxx, dyy, dxy, lame_lambda, shear_modulus):
    """sigma_k += lambda tr(d) I + 2 G d, plane strain (d_zz = 0); d_xy is the tensor shear."""
    volumetric = lame_lambda * (dxx + dyy)
    stress[k, 0] += volumetric + 2.0 * shear_modulus * dxx
    stress[k, 1] += volumetric + 2.0 * shear_modulus * dyy
    stress[k, 2] += volumetric
    stress[k, 3] += 2.0 * shear_modulus * dxy


@inner_kernel
def softened_strength(mat_params, m, plastic_strain):
    """(c, sin phi, cos phi, sin psi) of a softening Mohr-Coulomb material ``m`` at equivalent plastic
    strain ``plastic_strain``: c and phi move from peak to residual by the share s(eps) of the
    material's law (``scene.SOFTENING_LAWS``); psi stays as declared, at most phi."""
    start = mat_params[m, 8]
    span = mat_params[m, 9] - start
    share = 0.0
    if plastic_strain > start:
        if mat_params[m, 10] == 1.0:
            share = min((plastic_strain - start) / span, 1.0)
        else:
            share = 1.0 - math.exp(-3.0 * (plastic_strain - start) / span)
    cohesion = mat_params[m, 0] + share * (mat_params[m, 5] - mat_params[m, 0])
    phi = mat_params[m, 7] + share * (mat_params[m, 6] - mat_params[m, 7])
    sin_phi = math.sin(phi)
    return cohesion, sin_phi, math.cos(phi), min(mat_params[m, 3], sin_phi)


@inner_kernel
def update_stress(
    node_L, node_area, node_stress, node_plastic_strain, node_material, mat_model, mat_lambda, mat_shear, mat_params, dt,
    n_threads,
):
    """Rotate and update every particle's stress from its smoothed velocity gradient.

    Elastic rows take the Hooke increment; Drucker-Prager and Mohr-Coulomb rows the elastic
    trial and return map of ``plasticity``.  Adds the equivalent plastic strain increment to
    ``node_plastic_strain`` and returns the plastic work of the step, sum_k A_k sigma:d_eps_p (J/m),
    summed in fixed chunks of particles (``jit`` module doc); on threads unless ``n_threads`` is None
    (``jit.kernel_threads``).
    """
    n_node = node_stress.shape[0]
    n_chunk = n_chunks(n_node)
    chunk_work = np.zeros(n_chunk)
    if n_threads is not None:  # decided when compiling (jit.kernel_threads)
        update_stress_threaded(node_L, node_area, node_stress, node_plastic_strain, node_material, mat_model, mat_lambda,
                               mat_shear, mat_params, dt, chunk_work)
    else:  # the same chunks
        for chunk in range(n_chunk):
            start, end = chunk_bounds(chunk, n_node)
            chunk_work[chunk] = update_stress_range(
                node_L, node_area, node_stress, node_plastic_strain, node_material, mat_model, mat_lambda, mat_shear,
                mat_params, dt, start, end)
    plastic_work = 0.0
    for chunk in range(n_chunk):
        plastic_work += chunk_work[chunk]
    return plastic_work


@parallel_inner_kernel
def update_stress_threaded(node_L, node_area, node_stress, node_plastic_strain, node_material, mat_model, mat_lambda,
                           mat_shear, mat_params, dt, chunk_work):
    """:func:`update_stress_range` of every chunk of particles on threads, its work in ``chunk_work``."""
    n_node = node_stress.shape[0]
    for chunk in prange(chunk_work.shape[0]):
        start, end = chunk_bounds(chunk, n_node)
        chunk_work[chunk] = update_stress_range(
            node_L, node_area, node_stress, node_plastic_strain, node_material, mat_model, mat_lambda, mat_shear,
            mat_params, dt, start, end)


@inner_kernel
def update_stress_range(
    node_L, node_area, node_stress, node_plastic_strain, node_material, mat_model, mat_lambda, mat_shear, mat_params, dt,
    start, end,
):
    """:func:`update_stress` of particles start..end-1; their plastic work (J/m)."""
    plastic_work = 0.0
    for k in range(np.uint64(start), np.uint64(end)):  # unsigned: no negative-index wraparound code
        area = node_area[k]
        if area <= 0.0:
            continue  # a particle in no triangle carries its stress unchanged
        lxx = node_L[k, 0]
        lxy = node_L[k, 1]
        lyx = node_L[k, 2]
        lyy = node_L[k, 3]
        rotate_jaumann(node_stress, k, lxy, lyx, dt)
        m = node_material[k]
        dxx = lxx * dt
        dyy = lyy * dt
        dxy = 0.5 * (lxy + lyx) * dt
        model = mat_model[m]
        if model == MODEL_ELASTIC:
            elastic_increment(node_stress, k, dxx, dyy, dxy, mat_lambda[m], mat_shear[m])
            continue
        if model == MODEL_DRUCKER_PRAGER:
            d_eq, work = drucker_prager_update(
                node_stress, k, dxx, dyy, dxy, mat_lambda[m], mat_shear[m],
                mat_params[m, 0], mat_params[m, 1], mat_params[m, 2],
            )
        elif mat_params[m, 10] == 0.0:
            d_eq, work = mohr_coulomb_update(
                node_stress, k, dxx, dyy, dxy, mat_lambda[m], mat_shear[m],
                mat_params[m, 0], mat_params[m, 1], mat_params[m, 2], mat_params[m, 3],
            )
        else:
            cohesion, sin_phi, cos_phi, sin_psi = softened_strength(mat_params, m, node_plastic_strain[k])
            d_eq, work = mohr_coulomb_update(
                node_stress, k, dxx, dyy, dxy, mat_lambda[m], mat_shear[m], cohesion, sin_phi, cos_phi, sin_psi,
            )
        tensile_strength = mat_params[m, 4]
        if tensile_strength < math.inf:
            d_eq_t, work_t = tension_cutoff(node_stress, k, model == MODEL_DRUCKER_PRAGER, tensile_strength,
                                            mat_lambda[m], mat_shear[m])
            d_eq += d_eq_t
            work += work_t
        node_plastic_strain[k] += d_eq
        plastic_work += area * work
    return plastic_work


@inner_kernel
def elastic_energy_density(sxx, syy, szz, sxy, youngs_modulus, poisson_ratio):
    """Complementary energy per volume of an isotropic elastic state (J/m^3).

    w = [s_xx^2 + s_yy^2 + s_zz^2 - 2 nu (s_xx s_yy + s_yy s_zz + s_zz s_xx)] / (2E) + s_xy^2 / (2G)
    """
    shear_modulus = youngs_modulus / (2.0 * (1.0 + poisson_ratio))
    normal = sxx * sxx + syy * syy + szz * szz - 2.0 * poisson_ratio * (sxx * syy + syy * szz + szz * sxx)
    return normal / (2.0 * youngs_modulus) + sxy * sxy / (2.0 * shear_modulus)
