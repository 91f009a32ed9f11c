"""What training saw of its terrain curriculum: the episodes finished on each lane, per iteration, per curriculum stage
and over the run.

The env counts every finished episode on the lane it was played on, per lane group (``HexapodEnv.lane_counts``:
episodes and successes since the env was built, ``mdp/events.py`` ``lane_count_kernel``). :class:`LaneLog` reads those
counts once per iteration (the runner's one host read of the episode statistics is beside it) and gives

- the console's part of the iteration line (:meth:`LaneLog.line`): the top lane's share of the episodes finished in
  the current curriculum stage, the mean lane of the robots now, and the episodes finished per robot so far;
- TensorBoard scalars (:meth:`LaneLog.scalars`): ``Curriculum/stage_lane_share/lane_K`` for every lane (top lane
  first in the listing), ``Curriculum/stage_top_lane_share``, ``Curriculum/iteration_top_lane_share``,
  ``Curriculum/episodes_per_robot`` and, where the lanes hold several courses (``TerrainConfig.lane_courses``),
  ``Curriculum/COURSE/stage_top_lane_share`` and ``Curriculum/COURSE/mean_level``;
- the run's summary for ``timing.json`` (:meth:`LaneLog.summary`) and, when the last stage had fewer than
  :data:`TOO_FEW` of its finished episodes on the top lane, one line that says so (:meth:`LaneLog.verdict`);
- the hardest lane's heights, in metres and in units of the robot's leg length (:meth:`LaneLog.hardest`: a 6 cm rise
  is a quarter of the paper robot's 0.26 m leg, a seventh of the MX-Phoenix's 0.41 m), in the summary and the verdict.
"""

from __future__ import annotations

import numpy as np

#: a last stage with fewer of its finished episodes on the top lane than this share trained below the course's own
#: heights for most of it: the run says so at its end
TOO_FEW = 0.10


def shares(counts: np.ndarray) -> np.ndarray:
    """Each lane's share of the finished episodes in ``counts`` ((groups, levels, 2) or (levels, 2)), over the groups
    together: (levels,), NaN where none finished."""
    c = np.asarray(counts)
    per_lane = c[..., 0].reshape(-1, c.shape[-2]).sum(axis=0).astype(np.float64)
    total = per_lane.sum()
    return per_lane / total if total else np.full(per_lane.shape, np.nan)


class LaneLog:
    """The lane counts of one run (``env``: a ``HexapodEnv`` with a terrain curriculum)."""

    def __init__(self, env):
        self.env = env
        self.levels = env.cfg.terrain.levels
        self.groups = tuple(env.lane_groups)
        self.num_envs = env.num_envs
        self.start = env.lane_counts()  # counts when training began (a resumed env starts from zero too)
        self.stage_start, self.previous, self.now = self.start, self.start, self.start
        self.stage_index, self.stage_first_iteration = 0, 0

    def update(self) -> None:
        """Read the env's counts (once per iteration: one small host read)."""
        self.previous, self.now = self.now, self.env.lane_counts()

    def new_stage(self, index: int, iteration: int) -> None:
        """A curriculum stage begins: its shares count from here."""
        self.stage_start, self.stage_index, self.stage_first_iteration = self.now, index, iteration

    # -------------------------------------------------------------- what it saw
    def stage_counts(self) -> np.ndarray:
        return self.now - self.stage_start

    def run_counts(self) -> np.ndarray:
        return self.now - self.start

    def episodes_per_robot(self) -> float:
        return float(self.run_counts()[..., 0].sum()) / self.num_envs

    def mean_levels(self) -> tuple[float, dict[str, float]]:
        """The robots' mean lane now, over all and per lane group."""
        level, group = self.env.lane_levels().T
        per = {name: float(level[group == g].mean()) for g, name in enumerate(self.groups) if (group == g).any()}
        return float(level.mean()), per

    def line(self) -> str:
        """The console's part of an iteration's line."""
        stage = self.stage_counts()
        n = int(stage[..., 0].sum())
        top = f"{shares(stage)[-1]:.0%}" if n else "-"
        return f"  top lane {top} of {n} ep  {self.episodes_per_robot():.1f} ep/robot"

    def scalars(self) -> dict[str, float]:
        """TensorBoard's curriculum scalars of this iteration (module docstring)."""
        stage, step = self.stage_counts(), self.now - self.previous
        out = {f"Curriculum/stage_lane_share/lane_{k}": float(v) for k, v in enumerate(shares(stage))}
        out["Curriculum/stage_top_lane_share"] = float(shares(stage)[-1])
        out["Curriculum/iteration_top_lane_share"] = float(shares(step)[-1])
        out["Curriculum/episodes_per_robot"] = self.episodes_per_robot()
        if len(self.groups) > 1:
            _, per = self.mean_levels()
            for g, name in enumerate(self.groups):
                out[f"Curriculum/{name}/stage_top_lane_share"] = float(shares(stage[g])[-1])
                out[f"Curriculum/{name}/mean_level"] = per.get(name, float("nan"))
        return out

    def summary(self) -> dict:
        """What the run saw, for ``timing.json``: per lane (top lane first) the episodes and successes of the last
        stage and of the whole run, their shares, per lane group where there are several, the mean lane at the end
        and the episodes finished per robot."""
        mean, per = self.mean_levels()

        def block(counts: np.ndarray) -> dict:
            total = int(counts[..., 0].sum())
            lanes = counts.sum(axis=0) if counts.ndim == 3 else counts
            return {"episodes": total, "top_lane_share": float(shares(counts)[-1]) if total else None,
                    "lanes_top_first": [{"lane": k, "episodes": int(lanes[k, 0]), "successes": int(lanes[k, 1]),
                                         "share": float(lanes[k, 0]) / total if total else None}
                                        for k in reversed(range(self.levels))]}  # fmt: skip

        out = {"levels": self.levels, "lane_groups": list(self.groups), "mean_level_end": mean,
               "episodes_per_robot": self.episodes_per_robot(),
               "last_stage": {"stage": self.stage_index + 1, "first_iteration": self.stage_first_iteration,
                              **block(self.stage_counts())},
               "run": block(self.run_counts()), "hardest_lane": self.hardest()}  # fmt: skip
        if len(self.groups) > 1:
            out["per_group"] = {name: {"mean_level_end": per.get(name), "last_stage": block(self.stage_counts()[g]),
                                       "run": block(self.run_counts()[g])} for g, name in enumerate(self.groups)}
        return out

    def hardest(self) -> dict:
        """The top lane's heights per lane group: its step rise and block height [m] (those of its course: stepped
        rises, rugged blocks, complex both), each also in units of the robot's leg length (coxa, femur and tibia)."""
        from hexnewton.robot import leg_length
        from hexnewton.terrain.heightmap import lane_config

        cfg, leg = self.env.cfg, leg_length(self.env.cfg.robot)
        out = {"leg_length_m": leg}
        for g, name in enumerate(self.groups):
            lane = lane_config(cfg.terrain, self.levels - 1, g)
            heights = {"step_rise": lane.step_rise, "block_height": lane.block_height_max}
            kinds = {"rugged": ("block_height",), "stepped": ("step_rise",)}.get(name, tuple(heights))
            kept = {k: heights[k] for k in kinds}
            out[name] = {**{f"{k}_m": v for k, v in kept.items()}, **{f"{k}_legs": v / leg for k, v in kept.items()}}
        return out

    def hardest_line(self) -> str:
        """The hardest lane's heights in words: ``stepped 6 cm rises (0.23 leg)``, per lane group."""
        h = self.hardest()
        words = {"step_rise": "rises", "block_height": "blocks"}
        parts = [f"{name} " + ", ".join(f"{100 * v[f'{k}_m']:.3g} cm {w} ({v[f'{k}_legs']:.2f} leg)"
                                        for k, w in words.items() if f"{k}_m" in v)
                 for name, v in h.items() if name != "leg_length_m"]  # fmt: skip
        return f"the hardest lane: {'; '.join(parts)} (leg length {h['leg_length_m']:.3g} m)"

    def verdict(self) -> str:
        """One line on the last stage's top-lane share and the hardest lane's heights in leg lengths; it says when
        training rarely reached the top lane."""
        stage = self.stage_counts()
        n = int(stage[..., 0].sum())
        share = shares(stage)[-1] if n else 0.0
        head = (f"the last curriculum stage (from iteration {self.stage_first_iteration}) finished {n} episodes, "
                f"{share:.1%} on the top lane (lane {self.levels} of {self.levels}, the course itself); "
                f"{self.episodes_per_robot():.1f} episodes per robot in the run; {self.hardest_line()}")
        if share < TOO_FEW:
            return (head + f": below {TOO_FEW:.0%}, so the last stage trained mostly below the course's heights "
                    "(docs/training.md, \"What training saw\")")
        return head
