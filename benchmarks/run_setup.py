"""Where an SRF run's time goes on a worker apart from its steps, part by part:

    python -m benchmarks.run_setup
    python -m benchmarks.run_setup --studies quickstart --spacings 2 --srf 1.0 1.2 1.4

For each study (a probabilistic one: its realisation 0, as ``Realisations.study_of`` makes it) at its
own spacing and at each of ``--spacings``, the stages before the strength reduction are relaxed once
(``fos.gravity.run_gravity``, one thread), then ``fos.task.run_srf`` runs each F of ``--srf`` in this
process on one thread, as a worker runs it (``--repeats`` times each; the first run of a cloud pays
its first mesh, ``fos.task.first_mesh``, the later ones find it kept).  The functions ``run_srf``
calls are timed where it calls them:

- arguments: the pickle round trip of the study and F (a task's arguments, sent with every run; the
  gravity state is put on each worker once per case, ``fos.dask_runs``, timed apart as "gravity state");
- scene: ``scene.build_scene`` (cloud, materials, water, per-particle properties, supports, checks);
- first mesh: ``fos.task.first_mesh`` (Delaunay, alpha shape, adjacency, colouring; kept per cloud);
- simulation: ``stages.running.new_simulation`` (state arrays, masses, smoothing, critical step);
- stage set-up: ``stages.running.begin_stage`` from the gravity state;
- stepping: ``StrengthReductionStage.run_at`` (strength reduced at F, the stepping loop, rebuilds);
- result dataset: ``output.stage_file.stage_dataset`` (the run's records and final particles as a dataset);
- file bytes: ``output.writing.dataset_bytes`` (that dataset as a netCDF file in memory);
- set-up: the run less its steps (the rest: monitors, verdict, record).

Every part is processor time (``time.thread_time``: the run is on one thread, and on the shared
machine a wall time is mostly the other programs'), each row the least over the repeats; "run" is
``run_srf``'s processor time, "wall" its wall time.  What a worker would save by keeping a case's
prepared run in memory (its scene, simulation and stage set up from the gravity state, keyed by what
determines them) and handing each run a copy: "kept: copy" is ``copy.deepcopy`` of the simulation
after ``begin_stage`` (an upper bound: a cache would share the mesh, which no run changes), against
scene + simulation + stage set-up, which it would replace.  Once per case: the gravity state's
pickle round trip (how it reaches a worker), its file read by the client (``fos.gravity.read_gravity``,
a resumed study), the first mesh on the first run, and a run file's bytes made with and without the
variables every run of the case writes alike (:data:`CASE_CONSTANTS`) and with its variables
stacked into a few (:func:`stacked`), alternately.

    python -m benchmarks.run_setup --dask

runs the same F through one local worker (``fos.cluster.start_client``) as the engine submits them,
without and with the two Events of a search's run, in wall time: the run on the worker, the round
trip the client sees, and their difference (dask's share of the run's slot).
"""

from __future__ import annotations

import argparse
import contextlib
import copy
import os
import pickle
import sys
import tempfile
import time
import tomllib
from collections import defaultdict
from pathlib import Path

import xarray as xr

from spfem_core.warmup import warm_up
from workflows.fos import task
from workflows.fos.cluster import close_client, start_client
from workflows.fos.gravity import gravity_paths, read_gravity, run_gravity, write_gravity
from workflows.fos.keys import gravity_key
from workflows.output.writing import dataset_bytes
from workflows.probabilistic.study_type import Realisations
from workflows.scene import build_scene
from workflows.stages.running import begin_stage, new_simulation
from workflows.stages.strength_reduction import StrengthReductionStage
from workflows.study import parse_study
from workflows.study.toml_text import to_toml

ROOT = Path(__file__).resolve().parents[1]
STUDIES = ("quickstart", "probabilistic_c_phi", "probabilistic_undrained")
CASE_CONSTANTS = ("particle_x0", "particle_y0", "particle_material", "particle_mass", "monitor_particle", "monitor_x0",
                  "monitor_y0")
"""Variables of a run file that every run of a case (and every case of one cloud and density) writes alike."""
PARTS = ("scene", "first mesh", "simulation", "stage set-up", "stepping", "result dataset", "file bytes")


def case_study(name: str, spacing_m: float | None):
    """The study a worker runs for ``name`` at ``spacing_m`` (None: the file's): realisation 0 of a
    probabilistic study, else the study itself."""
    raw = tomllib.loads((ROOT / "studies" / f"{name}.toml").read_text())
    if spacing_m is not None:
        raw["geometry"]["spacing_m"] = spacing_m
    study = parse_study(to_toml(raw))
    if study.probabilistic is not None:
        study = Realisations(study).study_of(0)
    return study


@contextlib.contextmanager
def timed_parts(seconds: dict):
    """The functions ``fos.task.run_srf`` calls, each adding its processor time to ``seconds[part]``."""
    def timing(part, function):
        def timed(*args, **kwargs):
            start = time.thread_time()
            try:
                return function(*args, **kwargs)
            finally:
                seconds[part] += time.thread_time() - start
        return timed

    patched = {"build_scene": "scene", "first_mesh": "first mesh",
               "new_simulation": "simulation", "begin_stage": "stage set-up", "stage_dataset": "result dataset",
               "dataset_bytes": "file bytes"}
    originals = {name: getattr(task, name) for name in patched}
    run_at = StrengthReductionStage.run_at
    try:
        for name, function in originals.items():
            setattr(task, name, timing(patched[name], function))
        StrengthReductionStage.run_at = timing("stepping", run_at)
        yield
    finally:
        for name, function in originals.items():
            setattr(task, name, function)
        StrengthReductionStage.run_at = run_at


def measure(study, srfs, repeats: int) -> tuple[list[dict], dict]:
    """Per F: the least over ``repeats`` of each part and of the run; and the once-per-case costs."""
    gravity = run_gravity(study.source_text, threads=1)
    start = time.thread_time()
    pickle.loads(pickle.dumps(gravity.state))
    once = {"gravity state to a worker": time.thread_time() - start, "gravity": gravity.wall_time_s,
            "particles": gravity.n_particles}
    study_scene = build_scene(study, gravity.flow)
    task._first_meshes.clear()  # the first run of the cloud on this "worker" triangulates it
    rows = []
    for srf in srfs:
        best: dict = {}
        for _ in range(repeats):
            seconds: dict = defaultdict(float)
            start = time.thread_time()
            sent = pickle.loads(pickle.dumps((study, srf)))
            seconds["arguments"] = time.thread_time() - start
            start = time.thread_time()
            with timed_parts(seconds):
                result = task.run_srf(sent[0], gravity.state, sent[1], flow=gravity.flow)
            seconds["run"] = time.thread_time() - start
            seconds["run wall"] = result.finished_unix_s - result.started_unix_s
            seconds["set-up"] = seconds["run"] - seconds["stepping"]
            seconds["n_steps"] = result.record.n_steps
            once.setdefault("first mesh, first run", seconds["first mesh"])
            best = dict(seconds) if not best else {k: min(v, seconds[k]) for k, v in best.items()}
        rows.append({"srf": srf, **best})
    sim = new_simulation(study, study_scene, threads=1, initial_mesh=task.first_mesh(study_scene))
    begin_stage(study, sim, len(study.stages) - 1, start_from=gravity.state)
    copies = []
    for _ in range(repeats):
        start = time.thread_time()
        copy.deepcopy(sim)
        copies.append(time.thread_time() - start)
    once["kept: copy"] = min(copies)
    once.update(file_parts(result.dataset, repeats))
    with tempfile.TemporaryDirectory() as scratch:
        write_gravity(study, Path(scratch), gravity)
        start = time.thread_time()
        read_gravity(gravity_paths(study, Path(scratch))[-1], gravity_key(study))
        once["gravity file read"] = time.thread_time() - start
    return rows, once


def stacked(dataset):
    """``dataset`` with its variables of one set of dimensions and kind stacked into one, along a new
    dimension each (the same values in a few variables: what a run file's bytes cost per variable)."""
    groups: dict = {}
    for name, variable in dataset.data_vars.items():
        groups.setdefault((variable.dims, variable.dtype.kind), []).append(name)
    return xr.Dataset({f"stack{i}": xr.concat([dataset[name].drop_vars(list(dataset[name].coords)) for name in names],
                                              dim=f"stacked{i}")
                       for i, names in enumerate(groups.values())})


def file_parts(dataset, repeats: int) -> dict:
    """The run file's bytes made from the whole dataset, from it without the variables every run of the
    case writes alike (:data:`CASE_CONSTANTS`) and from its variables stacked (:func:`stacked`),
    alternately, each the least of 5 ``repeats``."""
    constants = [name for name in CASE_CONSTANTS if name in dataset.variables]
    variants = {"file bytes": dataset, "file bytes, no constants": dataset.drop_vars(constants),
                "file bytes, stacked": stacked(dataset)}
    times: dict = {name: [] for name in variants}
    for _ in range(5 * repeats):
        for name, made in variants.items():
            start = time.thread_time()
            dataset_bytes(made)
            times[name].append(time.thread_time() - start)
    return {**{name: min(values) for name, values in times.items()}, "variables": len(dataset.data_vars),
            "constants": len(constants), "stacks": len(variants["file bytes, stacked"].data_vars)}


def measure_dask(client, study, srfs, repeats: int) -> list[dict]:
    """Per F, on one local worker as the engine submits runs (``fos.dask_runs``: the study and F as
    arguments, the gravity state a task's result held on the worker): the run's wall on the worker and
    its round trip as the client sees it (submitted to result fetched), without the two Events of a
    search's run and with them (a ``distributed.Event`` looked up at every stop-rule check); the least
    of ``repeats``."""
    gravity = run_gravity(study.source_text, threads=1)
    held = client.submit(task.held, gravity.state, pure=False)
    client.submit(task.run_srf, study, held, srfs[0], flow=gravity.flow, pure=False).result()  # warm
    rows = []
    for srf in srfs:
        best: dict = {}
        for i in range(repeats):
            for events in (False, True):
                names = dict(cancel_event=f"run-setup-cancel-{srf}-{i}", failing_event=f"run-setup-failing-{srf}-{i}")
                start = time.perf_counter()
                result = client.submit(task.run_srf, study, held, srf, flow=gravity.flow, pure=False,
                                       **(names if events else {})).result()
                trip = time.perf_counter() - start
                run = result.finished_unix_s - result.started_unix_s
                label = "events" if events else "no events"
                for name, value in ((f"trip, {label}", trip), (f"run, {label}", run)):
                    best[name] = min(best.get(name, value), value)
        rows.append({"srf": srf, "particles": gravity.n_particles, **best})
    return rows


def main_dask(args) -> int:
    client, cluster = start_client(1, None)
    try:
        print(f"one local worker; load {os.getloadavg()[0]:.1f}; times in ms, least of {args.repeats}")
        print("| study | h (m) | particles | F | run on the worker | round trip | dask | run, with Events | "
              "round trip, with Events | dask, with Events |")
        print("|---|---|---|---|---|---|---|---|---|---|")
        for name in args.studies:
            for spacing_m in (None, *args.spacings):
                study = case_study(name, spacing_m)
                for row in measure_dask(client, study, args.srf, args.repeats):
                    cells = []
                    for label in ("no events", "events"):
                        run, trip = row[f"run, {label}"], row[f"trip, {label}"]
                        cells += [f"{1e3 * run:.1f}", f"{1e3 * trip:.1f}", f"{1e3 * (trip - run):.1f}"]
                    print(f"| {name} | {study.geometry.spacing_m:g} | {row['particles']} | {row['srf']:g} | "
                          + " | ".join(cells) + " |")
    finally:
        close_client(client, cluster)
    print(f"load {os.getloadavg()[0]:.1f}")
    return 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.run_setup", description=__doc__.splitlines()[0])
    parser.add_argument("--studies", nargs="+", default=STUDIES, choices=STUDIES)
    parser.add_argument("--spacings", nargs="+", type=float, default=[2.0], help="besides each study's own (m)")
    parser.add_argument("--srf", nargs="+", type=float, default=[1.0, 1.3])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--dask", action="store_true", help="the runs' round trips through one local worker")
    args = parser.parse_args(argv)
    if args.dask:
        return main_dask(args)
    warm_up()
    print(f"load {os.getloadavg()[0]:.1f}; processor times in ms, least of {args.repeats}")
    print("| study | h (m) | particles | F | steps | arguments | " + " | ".join(PARTS) +
          " | run | set-up | set-up share | kept: copy | wall |")
    print("|---|---|---|---|---|---|" + "---|" * (len(PARTS) + 5))
    for name in args.studies:
        for spacing_m in (None, *args.spacings):
            study = case_study(name, spacing_m)
            rows, once = measure(study, args.srf, args.repeats)
            for row in rows:
                parts = " | ".join(f"{1e3 * row.get(part, 0.0):.1f}" for part in PARTS)
                print(f"| {name} | {study.geometry.spacing_m:g} | {once['particles']} | {row['srf']:g} | "
                      f"{row['n_steps']:.0f} | {1e3 * row['arguments']:.1f} | {parts} | {1e3 * row['run']:.1f} | "
                      f"{1e3 * row['set-up']:.1f} | {row['set-up'] / row['run']:.0%} | "
                      f"{1e3 * once['kept: copy']:.1f} | {1e3 * row['run wall']:.1f} |")
            print(f"|  | once per case on a worker: gravity state {1e3 * once['gravity state to a worker']:.1f} ms "
                  f"(its file read by the client {1e3 * once['gravity file read']:.1f} ms; relaxing it "
                  f"{once['gravity']:.2f} s), first mesh on the first run {1e3 * once['first mesh, first run']:.1f} "
                  f"ms; a run file's {once['variables']} variables {1e3 * once['file bytes']:.1f} ms, without the "
                  f"{once['constants']} every run writes alike {1e3 * once['file bytes, no constants']:.1f} ms, "
                  f"stacked in {once['stacks']} {1e3 * once['file bytes, stacked']:.1f} ms |")
    print(f"load {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
