"""Throughput over GPUs of one host, as ``hexnewton-bench`` reports it under torchrun at 1, 2, 4 ... GPUs: each rank's
rows (:func:`rate_rows`), the ranks' rates gathered (:func:`with_ranks`), the total and the scaling efficiency
(:func:`scaling_rows`, :func:`scaling_markdown`).

A bench run's rates are per rank (each rank one GPU, ``cuda:LOCAL_RANK``); the total is their sum, and the scaling
efficiency at K GPUs is ``total / (K x the 1-GPU rate)`` at the same envs per GPU. A training run's rate is its
env-steps (all ranks) over its training seconds.
"""

from __future__ import annotations

#: what each bench measure counts per second
UNITS = {"sim": "robot-s/s", "env": "env-steps/s", "train": "env-steps/s"}
#: the throughput scaling the issue asks for
TARGET_EFFICIENCY = 0.90


def percent(v: float | None) -> str:
    """A rate as a percentage with one decimal; a dash for none."""
    return "—" if v is None else f"{100 * v:.1f} %"


def rate_rows(sim: list, pipeline: list) -> list[dict]:
    """One row per measurement of this process (``BenchResult`` / ``PipelineResult`` objects): measure, terrain, envs
    on this rank and its rate (``UNITS``), in a fixed order so that every rank's rows line up."""
    rows = [{"measure": "sim", "terrain": r.terrain, "num_envs": r.num_envs, "rate": r.robot_s_per_s} for r in sim]
    for r in pipeline:
        for measure, rate in (("env", r.env_steps_per_s), ("train", r.train_steps_per_s)):
            if rate == rate:  # measured (NaN: that mode was not asked for)
                rows.append({"measure": measure, "terrain": r.terrain, "num_envs": r.num_envs, "rate": rate})
    return rows


def with_ranks(rows: list[dict], per_rank: list[list[float]]) -> list[dict]:
    """``rows`` (rank 0's) with every rank's rate (``per_rank[rank][row]``, :func:`~hexnewton.learning.runner.
    gather_floats`) and their sum."""
    out = []
    for k, row in enumerate(rows):
        rates = [float(ranks[k]) for ranks in per_rank]
        out.append({**{key: row[key] for key in ("measure", "terrain", "num_envs")}, "per_rank": rates,
                    "total": sum(rates)})  # fmt: skip
    return out


def scaling_rows(runs: list[dict]) -> list[dict]:
    """Rows over bench runs (each ``hexnewton-bench --json`` output with ``world_size`` and ``ranks``): per measure,
    terrain, envs per GPU and GPU count, the total and per-GPU rate and the efficiency against the 1-GPU run's rate
    at the same envs per GPU (None without one)."""
    single = {}
    for run in runs:
        if run["world_size"] == 1:
            for r in run["ranks"]:
                single[(r["measure"], r["terrain"], r["num_envs"])] = r["total"]
    rows = []
    for run in sorted(runs, key=lambda r: r["world_size"]):
        k = run["world_size"]
        for r in run["ranks"]:
            base = single.get((r["measure"], r["terrain"], r["num_envs"]))
            rows.append({"measure": r["measure"], "terrain": r["terrain"], "envs_per_gpu": r["num_envs"], "gpus": k,
                         "device_name": run.get("device_name", "?"), "total": r["total"], "per_gpu": r["total"] / k,
                         "per_rank": r["per_rank"], "efficiency": r["total"] / (k * base) if base else None})  # fmt: skip
    return sorted(rows, key=lambda r: (r["measure"], r["terrain"], r["envs_per_gpu"], r["gpus"]))


def scaling_markdown(rows: list[dict]) -> str:
    """The table of :func:`scaling_rows`, the efficiency marked against ``TARGET_EFFICIENCY``."""
    md = ("| measure | terrain | envs per GPU | GPUs | total | per GPU | slowest / fastest rank | efficiency |\n"
          "|---|---|---:|---:|---:|---:|---:|---:|\n")  # fmt: skip
    for r in rows:
        eff = percent(r["efficiency"]) + ("" if r["efficiency"] is None or r["gpus"] == 1 or
                                       r["efficiency"] >= TARGET_EFFICIENCY else " (below 90 %)")  # fmt: skip
        spread = min(r["per_rank"]) / max(r["per_rank"]) if max(r["per_rank"]) else None
        md += (f"| {r['measure']} | {r['terrain']} | {r['envs_per_gpu']} | {r['gpus']} | {r['total']:,.0f} "
               f"{UNITS[r['measure']]} | {r['per_gpu']:,.0f} | {percent(spread)} | {eff} |\n")  # fmt: skip
    return md
