"""Keys of the cached states of a strength-reduction study: what a stored file was made from.

A gravity file carries ``gravity_key``, a hash over everything that shapes the gravity state
(geometry, materials, loads, water, supports, solver, the stages before the strength reduction, and
the core's sources; not the ``[study]`` table, whose name and description change no number, so a
renamed study reuses its files; not the materials' strength when every stage before the strength
reduction is elastic, so that a sweep over strength, or the realisations of random strengths,
relax gravity once; not the seismic load when it acts in the runs only); a run file carries
``run_key``, a hash over the gravity key, what the run does (the seismic load and the random field
too) and its SRF.  A later invocation reuses a file whose key matches and recomputes the rest.
The search's own settings are left out of the run key: refining the search reuses every run.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json

from spfem_core.jit import source_hash
from workflows.study import Study

SEARCH_FIELDS = ("srf_min", "srf_max", "srf_step", "fos_tolerance", "max_runs")
"""Fields of the strength-reduction stage that choose which runs to make, not what a run does."""



def _digest(payload) -> str:
    text = json.dumps(payload, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:24]


def _remembered(function):
    """``function`` of a study, remembered for the last 4,096 studies (a sweep's or a probabilistic
    study's cases ask for their keys many times); computed each time for a study that cannot be
    hashed (a table holding an inline TOML table)."""
    remembered = functools.lru_cache(maxsize=4096)(function)

    @functools.wraps(function)
    def keyed(study, *args):
        try:
            hash(study)
        except TypeError:
            return function(study, *args)
        return remembered(study, *args)

    return keyed


@_remembered
def gravity_key(study: Study) -> str:
    """Hash of everything that shapes the gravity state (module doc); equal studies, equal keys."""
    raw = dataclasses.asdict(study)
    for key in ("source_text", "study", "output", "metrics"):  # what changes no number of the state
        raw.pop(key, None)
    raw["stages"] = raw["stages"][:-1]
    seismic = study.loads.seismic
    if seismic is not None and not seismic.in_gravity:
        raw["loads"].pop("seismic")  # it acts in the runs only: in the run key
    if all(stage.elastic for stage in study.stages[:-1]):  # a model's own fields: what an elastic stage ignores
        raw["materials"] = [{k: v for k, v in fields.items() if k not in material.strength_fields()}
                            for material, fields in zip(study.materials, raw["materials"])]
        if study.random_field is not None:  # random strengths alone: one gravity state for every realisation
            strengths = {m.name: m.strength_fields() for m in study.materials}
            if all(p.property in strengths[p.material] for p in study.random_field.properties):
                raw.pop("random_field")
    raw["core"] = source_hash()
    return _digest(raw)


@_remembered
def run_key(study: Study, srf: float, stop_at_failure: bool = False) -> str:
    """Hash of the gravity key, the materials (their strength too), what a run does (not how the
    search picks runs; ``stop_at_failure``: whether it ends at the failure displacement,
    ``fos.task.RunPolicy``) and F."""
    stage = dataclasses.asdict(study.strength_reduction)
    for key in SEARCH_FIELDS:
        stage.pop(key)
    materials = [{"model": material.model, **dataclasses.asdict(material)} for material in study.materials]
    seismic = study.loads.seismic
    payload = {"gravity": gravity_key(study), "materials": materials, "stage": stage, "srf": f"{srf:.4f}",
               "seismic": None if seismic is None else dataclasses.asdict(seismic)}
    if study.random_field is not None:
        payload["random_field"] = dataclasses.asdict(study.random_field)
    if stop_at_failure:  # (left out otherwise: the keys of runs made before it existed still hold)
        payload["stop_at_failure"] = True
    return _digest(payload)


def case_key(study: Study) -> str:
    """Hash of everything a study computes and how its search picks runs: equal keys, equal
    results (the cases of a sweep that share one are computed once)."""
    stage = study.strength_reduction
    return _digest({"run": run_key(study, 0.0), "search": {name: getattr(stage, name) for name in SEARCH_FIELDS}})
