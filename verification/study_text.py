"""The small study files that tests and verification run, built from their parts in one place.

A study file here is a dict of its tables written as TOML (``workflows.study.toml_text.to_toml``):
:func:`study_text` puts ``[study]``, ``[geometry]`` and ``[[materials]]`` first and the
``[[stages]]`` last, and the parts the tests share are the functions below: the coarse drained
soil, gravity, a base and sides held, the elastic gravity stage and the strength-reduction stage.
A test states only what its study adds or changes (``drained_soil(cohesion_pa=5e3)``).
"""

from __future__ import annotations

from workflows.study.toml_text import to_toml

COARSE_SLOPE_M = [[0.0, 0.0], [30.0, 0.0], [30.0, 3.0], [20.0, 3.0], [10.0, 8.0], [0.0, 8.0]]
"""A 5 m high slope at 1V:2H on a 3 m foundation, its toe at x = 20 m (the fuzzer's slope)."""


def box_m(width_m: float, height_m: float, x0_m: float = 0.0) -> list[list[float]]:
    """The polygon of a rectangle from (x0, 0) to (x0 + width, height), counter-clockwise."""
    return [[x0_m, 0.0], [x0_m + width_m, 0.0], [x0_m + width_m, height_m], [x0_m, height_m]]


def drained_soil(**changes) -> dict:
    """A Drucker-Prager soil: rho = 2000 kg/m3, E = 100 MPa, nu = 0.3, c = 10 kPa, phi = 20 deg
    (fields given in ``changes`` replace or join these)."""
    return {"name": "soil", "model": "drucker_prager", "density_kg_m3": 2000.0, "youngs_modulus_pa": 1e8,
            "poisson_ratio": 0.3, "cohesion_pa": 10e3, "friction_deg": 20.0, **changes}


def elastic_soil(**changes) -> dict:
    """An elastic soil: rho = 2000 kg/m3, E = 10 MPa, nu = 0.3 (``changes`` replace or join these)."""
    return {"name": "soil", "model": "elastic", "density_kg_m3": 2000.0, "youngs_modulus_pa": 1e7,
            "poisson_ratio": 0.3, **changes}


def gravity(g_m_s2: float = 10.0) -> dict:
    """The ``[loads]`` table of gravity ``g`` downwards."""
    return {"gravity_m_s2": [0.0, -g_m_s2]}


def held_base_and_sides(left_x_m: float | None = 0.0, right_x_m: float | None = None) -> list[dict]:
    """``[[boundary]]``: the base (y <= 0) held in x and y, the side at ``left_x_m`` ("sides") and the one at
    ``right_x_m`` ("right") held in x; None leaves that side free."""
    boundary = [{"name": "base", "y_max_m": 0.0, "vx_m_s": 0.0, "vy_m_s": 0.0}]
    if left_x_m is not None:
        boundary.append({"name": "sides", "x_max_m": left_x_m, "vx_m_s": 0.0})
    if right_x_m is not None:
        boundary.append({"name": "right", "x_min_m": right_x_m, "vx_m_s": 0.0})
    return boundary


def gravity_stage(max_duration_s: float, record_interval_s: float, **more) -> dict:
    """The elastic relaxation stage "gravity" (``more``: its other fields, e.g. ``tolerance``)."""
    return {"name": "gravity", "kind": "relaxation", "elastic": True, **more, "max_duration_s": max_duration_s,
            "record_interval_s": record_interval_s}


def srf_stage(duration_s: float, record_interval_s: float, srf_min: float = 1.0, srf_max: float = 2.0,
              srf_step: float = 0.1, **more) -> dict:
    """The strength-reduction stage "srf" from ``srf_min`` to ``srf_max`` by ``srf_step`` (``more``: its
    other fields, e.g. ``fos_tolerance``, ``max_runs``)."""
    return {"name": "srf", "kind": "strength_reduction", "duration_s": duration_s,
            "record_interval_s": record_interval_s, "srf_min": srf_min, "srf_max": srf_max, "srf_step": srf_step,
            **more}


def slope_form(height_m: float, gradient: float, **more) -> dict:
    """``[geometry.slope]``: a slope ``height_m`` high at 1V:``gradient``H (``more``: foundation_depth_m, ...)."""
    return {"height_m": height_m, "gradient": gradient, **more}


def study_text(name: str, geometry: dict, materials: list[dict], stages: list[dict], **tables) -> str:
    """The TOML text of the study ``name``: its geometry, materials, the other ``tables`` in their order
    (``loads``, ``water``, ``boundary``, ``monitors``, ...) and its stages."""
    return to_toml({"study": {"name": name}, "geometry": geometry, "materials": materials, **tables,
                    "stages": stages})


def coarse_slope_text(name: str = "slope", polygon_m=COARSE_SLOPE_M, left_x_m: float = 0.0, max_runs: int = 4,
                      soil: dict | None = None, **tables) -> str:
    """The coarse drained slope (h = 1 m) of :data:`COARSE_SLOPE_M` held at its base and at ``left_x_m``,
    with a short gravity stage and an SRF search from 1 to 1.4 in at most ``max_runs`` runs: a study that
    computes an FOS in seconds (``soil``: changes to :func:`drained_soil`; ``tables``: more tables)."""
    return study_text(name, {"polygon_m": polygon_m, "spacing_m": 1.0}, [drained_soil(**(soil or {}))],
                      coarse_slope_stages(max_runs), loads=gravity(), boundary=held_base_and_sides(left_x_m),
                      **tables)


def coarse_slope_stages(max_runs: int = 4) -> list[dict]:
    """The stages of :func:`coarse_slope_text`: 5 s of elastic gravity, SRF runs of 1 s from 1 to 1.4."""
    return [gravity_stage(5.0, 0.1), srf_stage(1.0, 0.05, 1.0, 1.4, 0.2, fos_tolerance=0.1, max_runs=max_runs)]
