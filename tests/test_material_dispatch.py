"""The one dispatch on the material model (``constitutive.update_stress_range``): a row of every
model of ``materials.MODELS`` reaches that model's own return map, and a model code without a
branch there stops the update instead of running another model's return map."""

from __future__ import annotations

import inspect
import math

import numpy as np
import pytest

from spfem_core.constitutive import update_stress
from spfem_core.jit import PARALLEL_CHUNK, kernel
from spfem_core.materials import MODELS, elastic
from spfem_core.materials.table import MaterialTable

DT_S = 1.0
VELOCITY_GRADIENT_1_S = (1e-3, 5e-4, 5e-4, -2e-3)  # (xx, xy, yx, yy) 1/s: symmetric, so no Jaumann rotation
STRESS_PA = (-1e5, -2e5, -1.5e5, 3e4)  # (xx, yy, zz, xy), in compression
AREA_M2 = 0.25
RETURN_MAP_LEADING = ("stress", "k_row", "dxx", "dyy", "dxy", "lame_lambda", "shear_modulus")
"""The arguments every return map ``<model>_update`` takes before its constants."""


@kernel
def dispatched(node_L, node_area, node_stress, node_plastic_strain, node_material_row, mat_model, mat_lambda,
               mat_shear, mat_params, dt, threaded):
    """``constitutive.update_stress`` (no Python entry of its own), on threads or not."""
    if threaded:
        return update_stress(node_L, node_area, node_stress, node_plastic_strain, node_material_row, mat_model,
                             mat_lambda, mat_shear, mat_params, dt, 2)
    return update_stress(node_L, node_area, node_stress, node_plastic_strain, node_material_row, mat_model,
                         mat_lambda, mat_shear, mat_params, dt, None)


def weak_row(model) -> MaterialTable:
    """One row of ``model``: its defaults, and every property without one just above its lower
    bound (1 Pa, 1 degree, ...), so that the stress above yields whatever the model."""
    given = {prop.name: (prop.ge if math.isfinite(prop.ge) else 0.0) + 1.0
             for prop in model.PROPERTIES if prop.default is None}
    return MaterialTable.single("row", model.NAME, 2000.0, 5e7, 0.3, **given)


def through_dispatch(table: MaterialTable, n_particles: int = 1, threaded: bool = False):
    """(stress, plastic strain, plastic work) of ``n_particles`` of row 0 after one update."""
    node_L = np.tile(VELOCITY_GRADIENT_1_S, (n_particles, 1))
    stress = np.tile(STRESS_PA, (n_particles, 1))
    strain = np.zeros(n_particles)
    rows = np.zeros(n_particles, dtype=np.int64)
    work = dispatched(node_L, np.full(n_particles, AREA_M2), stress, strain, rows, table.model, table.lame_lambda_pa,
                      table.shear_modulus_pa, table.kernel_constants(), DT_S, threaded)
    return stress, strain, work


def directly(model, table: MaterialTable):
    """(stress, plastic strain, plastic work) of the model's own return map on the same increment."""
    lxx, lxy, lyx, lyy = VELOCITY_GRADIENT_1_S
    increment = (lxx * DT_S, lyy * DT_S, 0.5 * (lxy + lyx) * DT_S)
    stress = np.array([STRESS_PA])
    moduli = (table.lame_lambda_pa[0], table.shear_modulus_pa[0])
    if model is elastic:
        elastic.elastic_increment(stress, 0, *increment, *moduli)
        return stress, 0.0, 0.0
    return_map = getattr(model, f"{model.NAME}_update")
    arguments = list(inspect.signature(return_map.py_func).parameters)
    assert tuple(arguments[:len(RETURN_MAP_LEADING)]) == RETURN_MAP_LEADING, model.NAME
    constants = table.kernel_constants()[0, :len(arguments) - len(RETURN_MAP_LEADING)]  # in the order of CONSTANTS
    d_eq, work = return_map(stress, 0, *increment, *moduli, *constants)
    return stress, d_eq, AREA_M2 * work


@pytest.mark.parametrize("model", MODELS, ids=[model.NAME for model in MODELS])
def test_a_row_of_every_registered_model_reaches_its_own_return_map(model):
    table = weak_row(model)
    stress, strain, work = through_dispatch(table)
    own_stress, own_strain, own_work = directly(model, table)
    np.testing.assert_allclose(stress, own_stress, rtol=1e-12, atol=1e-9)
    assert strain[0] == pytest.approx(own_strain, rel=1e-12, abs=1e-300)
    assert work == pytest.approx(own_work, rel=1e-12, abs=1e-300)
    if model is not elastic:  # the row yielded: a return map ran, not the trial alone
        assert strain[0] > 0.0 and work > 0.0


@pytest.mark.parametrize("threaded", [False, True], ids=["one thread", "threads"])
def test_a_model_code_without_its_branch_stops_the_update(threaded):
    """A model registered in MODELS without its branch in the dispatch: the update raises, on
    threads too (where an exception raised inside the threads would be lost), and does not run
    another model's return map in silence."""
    table = weak_row(MODELS[-1])
    unregistered = len(MODELS)
    table_model = np.array([unregistered], dtype=np.int64)
    n = 2 * PARALLEL_CHUNK + 7  # three chunks; the row of the last particle only is unregistered
    node_L = np.tile(VELOCITY_GRADIENT_1_S, (n, 1))
    stress, strain = np.tile(STRESS_PA, (n, 1)), np.zeros(n)
    rows = np.zeros(n, dtype=np.int64)
    rows[-1] = 1
    model = np.concatenate([table.model, table_model])
    lame, shear = np.repeat(table.lame_lambda_pa, 2), np.repeat(table.shear_modulus_pa, 2)
    params = np.repeat(table.kernel_constants(), 2, axis=0)
    with pytest.raises(ValueError, match="no branch for the material model of code") as raised:
        dispatched(node_L, np.full(n, AREA_M2), stress, strain, rows, model, lame, shear, params, DT_S, threaded)
    assert raised.value.args[-1] == unregistered
