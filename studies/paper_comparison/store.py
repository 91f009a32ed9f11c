"""A study kept across GPU leases: the runs and evaluations of ``studies/device/gpu.sh methods`` / ``evals``, stored
in a folder on the main branch so that the next lease skips what is finished and the report reads them all.

Layout (the same as ``gpu.sh``'s ``$RUNS/methods`` and ``$RUNS/method_evals``, so a stored study is copied back
there before a lease's queues start)::

    STUDY/runs/<method>_s<seed>.done                  the run's command, GPU and process time (JSON)
    STUDY/runs/<method>_s<seed>/<run>/config.json     as written by the run
    STUDY/runs/<method>_s<seed>/<run>/events.*        the scalars Fig. 5a and the budget table read (STORED_TAGS)
    STUDY/runs/<method>_s<seed>/<run>/model_<N>.pt    the last checkpoint, its policy alone (what evaluate loads)
    STUDY/evals/<method>_s<seed>_<terrain>[_sampled]/{results.json,report.md}
    STUDY/leases.json                                 one entry per lease: date, GPU kind, device seconds, what ran

:func:`store` copies a lease's finished runs and evaluations into a study, skipping those already there.
"""

from __future__ import annotations

import glob
import json
import os
import shutil

from hexnewton.analysis.curves import TAGS

#: The scalars a stored run keeps: the learning curves and the loop's time (``studies/paper_comparison/compare.py``'s budget).
STORED_TAGS = (*TAGS, "Perf/wall_time_s", "Perf/collection_time", "Perf/learning_time")


def _copy_scalars(src: str, dest: str) -> int:
    """The :data:`STORED_TAGS` of the TensorBoard events in ``src`` rewritten into ``dest`` with their steps and wall
    times; returns the number of points."""
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator
    from torch.utils.tensorboard import SummaryWriter

    acc = EventAccumulator(src, size_guidance={"scalars": 0})
    acc.Reload()
    tags = [t for t in STORED_TAGS if t in set(acc.Tags().get("scalars", []))]
    if not tags:
        raise ValueError(f"no TensorBoard scalars under {src}")
    writer = SummaryWriter(dest)
    n = 0
    for tag in tags:
        for e in acc.Scalars(tag):
            writer.add_scalar(tag, e.value, e.step, walltime=e.wall_time)
            n += 1
    writer.close()
    return n


def store_run(done: str, dest_runs: str) -> str | None:
    """Copy the run that ``done`` (``<method>_s<seed>.done``) marks finished into ``dest_runs``: its config, its
    scalars and its last checkpoint's policy; None when the study already holds it."""
    from hexnewton.learning.checkpoint import save_policy_only

    name = os.path.basename(done)[: -len(".done")]
    if os.path.exists(os.path.join(dest_runs, name + ".done")):
        return None
    runs = sorted(d for d in glob.glob(os.path.join(os.path.dirname(done), name, "*")) if os.path.isdir(d))
    if not runs:
        raise ValueError(f"{done}: no run folder {name}/<run>/ beside it")
    run = runs[-1]
    ckpts = sorted(glob.glob(os.path.join(run, "model_*.pt")), key=lambda p: (len(p), p))
    ckpts = [p for p in ckpts if os.path.basename(p)[6:-3].isdigit()]
    if not ckpts:
        raise ValueError(f"{run}: no model_<N>.pt checkpoint")
    out = os.path.join(dest_runs, name, os.path.basename(run))
    tmp = out + ".part"
    shutil.rmtree(tmp, ignore_errors=True)
    os.makedirs(tmp)
    shutil.copy2(os.path.join(run, "config.json"), tmp)
    _copy_scalars(run, tmp)
    save_policy_only(ckpts[-1], os.path.join(tmp, os.path.basename(ckpts[-1])))
    os.replace(tmp, out)
    shutil.copy2(done, os.path.join(dest_runs, name + ".done"))  # last: a run counts as stored once this exists
    return name


def store_eval(src: str, dest_evals: str) -> str | None:
    """Copy one evaluation folder's ``results.json`` and ``report.md`` into ``dest_evals``; None when the study already
    holds it or it did not finish (no results.json)."""
    name = os.path.basename(os.path.normpath(src))
    out = os.path.join(dest_evals, name)
    if os.path.exists(os.path.join(out, "results.json")) or not os.path.isfile(os.path.join(src, "results.json")):
        return None
    os.makedirs(out, exist_ok=True)
    for f in ("report.md", "results.json"):  # results.json last: an evaluation counts as stored once it exists
        if os.path.isfile(os.path.join(src, f)):
            shutil.copy2(os.path.join(src, f), out)
    return name


def store(runs: str | None, evals: str | None, study: str) -> dict[str, list[str]]:
    """Copy a lease's finished runs (``runs``: ``gpu.sh``'s ``$RUNS/methods``) and evaluations (``evals``:
    ``$RUNS/method_evals``) into ``study``; returns what was added."""
    added = {"runs": [], "evals": []}
    if runs:
        os.makedirs(os.path.join(study, "runs"), exist_ok=True)
        for done in sorted(glob.glob(os.path.join(runs, "*.done"))):
            name = store_run(done, os.path.join(study, "runs"))
            added["runs"] += [name] if name else []
    if evals:
        os.makedirs(os.path.join(study, "evals"), exist_ok=True)
        for src in sorted(d for d in glob.glob(os.path.join(evals, "*")) if os.path.isdir(d)):
            name = store_eval(src, os.path.join(study, "evals"))
            added["evals"] += [name] if name else []
    return added


def read_done(runs: str, name: str) -> dict:
    """A stored run's ``<name>.done`` (command, GPU, process seconds); {} when absent."""
    path = os.path.join(runs, name + ".done")
    if not os.path.isfile(path):
        return {}
    with open(path) as f:
        return json.load(f)


def read_leases(study: str) -> list[dict]:
    """``study/leases.json``: one entry per GPU lease ({} list when absent)."""
    path = os.path.join(study, "leases.json")
    if not os.path.isfile(path):
        return []
    with open(path) as f:
        return json.load(f)
