"""The verdict of the methods' comparison (``python studies/paper_comparison/compare.py``), claim by claim, written from the
study's ``results.json`` alone: every number a claim cites is read from it (Table 3 over seeds, Fig. 5a's numbers,
the paper's Table 3, the levels below), and each claim is worded by its numbers: "holds", "holds in part" or "does
not hold".

The levels (``results.json`` ``verdict_levels``):

- ``success``: the training success a curve must reach (Fig. 5a); ``window_env_steps``: how long it must stay at or
  above it for a *sustained* crossing (:func:`hexnewton.analysis.curves.crossings`);
- ``near``: the success at every distance below which "completes every task" no longer holds even in part;
- ``walks``: the 3 m success a method needs on a terrain to enter the stability comparison there (a robot that does
  not walk the course has little pitch or roll to show);
- ``paper_match``: how far (as a rate) a success may lie from the paper's Table 3 and still match it.
"""

from __future__ import annotations

from hexnewton.analysis.report import PAPER_TABLE3

VERDICT_LEVELS = {"success": 0.9, "window_env_steps": 1.0e6, "near": 0.95, "walks": 0.5, "paper_match": 0.10}
#: the paper's method names (PAPER_TABLE3) as the study's methods
PAPER_METHODS = {"CPG": "cpg", "TD3-CPG": "td3_cpg", "SAC-CPG": "sac_cpg", "CPG_RL": "cpg_rl"}
HOLDS, IN_PART, NOT = "holds", "holds in part", "does not hold"
#: the settings a method ran on where they were not chosen for it, as a claim about it names them: the task's reward
#: shaping, reward stages and knee-lift floor were chosen among CPG_RL variants, and every other method runs them with
#: learner settings not tuned for it (:data:`TUNING` says how each method's settings were chosen)
ON = {"sac_cpg": "on skrl's untuned `scale` preset", "td3_cpg": "on skrl's untuned `scale` preset",
      "a2c_cpg": "on CPG_RL's PPO settings, untuned for A2C", "joint": "on CPG_RL's PPO settings",
      "joint_staged": "on CPG_RL's PPO settings and reward stages without posture_reflex"}
#: how each method's settings were chosen: the report's section "Tuned and preset", ahead of the verdict
TUNING = [
    ("CPG_RL", "tuned: the task `complex`'s stability shaping (w_tilt 5, w_ang_vel 0.05, w_action_rate 0.1: "
               "`tasks.STABLE_SHAPING`), its reward stages (`tasks.STABLE_STAGES`: at 9.8 M env-steps posture_reflex "
               "2 with w_tilt 15 and w_ang_vel 0.1, at 19.7 M w_tilt 40 and w_ang_vel 0.3), its knee-lift floor "
               "(`cpg.a2_range` 0.9-1.3) and its terrain curriculum were chosen among CPG_RL variants "
               "(studies/stable_gait: variants/, posture_reflex/; studies/training_curves: curriculum/). Every other "
               "method here trains with this shaping, and every CPG method with these stages and this floor: chosen "
               "for CPG_RL, not for them."),
    ("SAC-CPG, TD3-CPG", "an untuned preset: skrl 2.1's `scale` preset (batch 32768, 2 gradient steps per vector "
                         "step, tau 0.1, learning rate 3e-4, a 4 M-transition replay buffer; docs/evaluation.md), "
                         "run as it is, with no setting of it tried against another on this task."),
    ("A2C-CPG", "CPG_RL's PPO settings where A2C has them (learning rate 1e-3, gamma 0.99, lambda 0.95, entropy "
                "0.005), untuned for A2C."),
    ("pure DRL (no stages, `complex-joint`; stages, `complex-joint-staged`)",
     "CPG_RL's PPO settings, untuned for 18 joint targets; with the stages, the reward weights of CPG_RL's stages at "
     "the same env-steps but not their posture_reflex, the CPG's levelling reflex, which joint targets do not have."),
    ("CPG_RL (task paper)", "Table 1's reward and Table 2's PPO as the paper gives them, at the paper's 10 ms frame, "
                            "without the terrain curriculum, the knee-lift floor, domain randomisation and the body "
                            "posture, one seed, ended by the 20-minute budget at 9.1 M env-steps: not the physics, "
                            "curriculum, seeds or budget of the other rows."),
]


def paper_table3() -> dict:
    """The paper's Table 3 as rates: {terrain: {method: [success at 0.5, 1, 2, 3 m]}}."""
    return {t: {PAPER_METHODS[m]: [v / 100.0 for v in row] for m, row in rows.items()} for t, rows in PAPER_TABLE3.items()}


def pct(v: float | None) -> str:
    return "—" if v is None else f"{100.0 * v:.1f} %"


def msteps(v: float | None) -> str:
    return "never" if v is None else f"{v / 1e6:.1f} M"


def deg2(v: float | None) -> str:
    return "—" if v is None else f"{v:.1f} deg²"


def _word(n_true: int, n_all: int) -> str:
    return HOLDS if n_all and n_true == n_all else IN_PART if n_true else NOT


def _mean(row: dict | None, key: str) -> float | None:
    return None if row is None or key not in row else row[key]["mean"]


def _span(row: dict, key: str) -> str:
    s = row[key]
    if s["n"] > 1:
        return f"{pct(s['mean'])} ({pct(s['min'])}-{pct(s['max'])})"
    return pct(s["mean"])


class Claims:
    """The verdict's claims over one ``results.json`` (``res``)."""

    def __init__(self, res: dict, label):
        self.res, self.label = res, label
        self.levels = res["verdict_levels"]
        self.det = res["table3"].get("deterministic", {})
        self.sampled = res["table3"].get("sampled", {})
        self.fig = res.get("fig5a", {})
        self.distances = res["meta"].get("distances", [])
        self.out: list[dict] = []

    def add(self, claim: str, word: str, text: str) -> None:
        self.out.append({"claim": claim, "verdict": word, "text": text})

    def _success(self, method: str) -> dict | None:
        return (self.fig.get("success", {}).get(method) or {}).get("mean")

    def _curve_text(self, method: str) -> str:
        c = self._success(method)
        level = self.levels["success"]
        if c is None:
            return f"{self.label(method)}: no curve"
        if c["first"] is None:
            s = f"{self.label(method)} never reaches {pct(level)}"
        else:
            s = f"{self.label(method)} first reaches {pct(level)} at {msteps(c['first'])} env-steps, " + (
                f"first holds it for {msteps(self.levels['window_env_steps'])} env-steps from "
                f"{msteps(c['sustained'])} on" if c["sustained"] is not None
                else f"never holds it for {msteps(self.levels['window_env_steps'])} env-steps")
        if c.get("dip_after_first") and c["dip_after_first"]["value"] < level:
            s += f" (after the first crossing it falls to {pct(c['dip_after_first']['value'])} at " \
                 f"{msteps(c['dip_after_first']['at'])})"  # fmt: skip
        return s + f", peaks at {pct(c['peak']['value'])} ({msteps(c['peak']['at'])}) and ends at " \
                   f"{pct(c['end']['value'])} ({msteps(c['end']['at'])})"  # fmt: skip

    def named(self, method: str) -> str:
        """A method's name with the settings it ran on where they were not chosen for it (:data:`ON`)."""
        return self.label(method) + (f" {ON[method]}" if method in ON else "")

    def last_checkpoint(self, method: str) -> str:
        """Where ``method``'s evaluation reads its last checkpoint after a training peak at the level: a sentence
        that says so (every seed peaked at or above the level, the mean ends below it), else ''."""
        c = self.fig.get("success", {}).get(method) or {}
        seeds, mean, level = c.get("per_seed") or [], c.get("mean"), self.levels["success"]
        if not seeds or mean is None or mean["end"]["value"] >= level or min(s["peak"]["value"] for s in seeds) < level:
            return ""
        at = [s["peak"]["at"] for s in seeds]
        name = self.label(method)
        return (f" {name[:1].upper() + name[1:]} is evaluated at each run's last checkpoint (the rule for every "
                f"method): its training success peaked at {' / '.join(pct(s['peak']['value']) for s in seeds)} per "
                f"seed ({msteps(min(at))}-{msteps(max(at))} env-steps) and ends at {pct(mean['end']['value'])}; no "
                "checkpoint from its peak is kept or evaluated.")

    def left_out(self, method: str, terrains: list[str]) -> str:
        """The runs of ``method`` left out of the means (cut short, ``excluded``) beside the kept seeds at the last
        distance (deterministic action), each terrain where one is above every kept seed said so; '' if none."""
        last = f"success_{self.distances[-1]:g}m" if self.distances else None
        ev = self.res.get("evaluations", {}).get("deterministic", {})
        out = []
        for name in self.res.get("excluded", {}):
            m, seed = name.rsplit("_s", 1)
            if m != method or last is None:
                continue
            parts, best = [], []
            for t in terrains:
                got, kept = (ev.get(t, {}).get(m) or {}).get(seed), self.det.get(t, {}).get(m)
                if got is None or kept is None or got.get(last) is None:
                    continue
                parts.append(f"{t} {pct(got[last])} (the kept seeds {pct(kept[last]['min'])}-{pct(kept[last]['max'])})")
                if got[last] > kept[last]["max"]:
                    best.append(t)
            if parts:
                steps = (self.res.get("budgets", {}).get(m, {}).get(seed) or {}).get("env_steps")
                out.append(f" Left out of the mean: seed {seed}, cut short at {msteps(steps)} env-steps, at "
                           f"{self.distances[-1]:g} m " + ", ".join(parts) + (
                               f": above every kept seed on {' and '.join(best)}." if best else "."))
        return "".join(out)

    def faster(self, others: tuple[str, ...], claim: str) -> None:
        """CPG_RL's mean training success sustains the level earlier than each of ``others``'s (or they never)."""
        cpg = self._success("cpg_rl")
        others = tuple(m for m in others if self._success(m) is not None)
        if cpg is None or not others:
            return
        ok = [m for m in others if cpg["sustained"] is not None
              and (self._success(m)["sustained"] is None or cpg["sustained"] < self._success(m)["sustained"])]
        text = "Mean training success over seeds (sampled actions, the last finished episodes): " + "; ".join(
            self._curve_text(m) for m in ("cpg_rl", *others)) + "."
        self.add(claim, _word(len(ok), len(others)), text)

    def higher(self, others: tuple[str, ...], claim: str) -> None:
        """CPG_RL's mean training success and curriculum level at the common budget above each of ``others``'s."""
        fig, common = self.fig, self.fig.get("common_env_steps")
        others = tuple(m for m in others if m in fig.get("success", {}))
        if "cpg_rl" not in fig.get("success", {}) or not others:
            return

        def at(tag, m):
            return ((fig.get(tag, {}).get(m) or {}).get("mean") or {}).get("at_common")

        ok = [m for m in others if (at("success", m) or 0) < (at("success", "cpg_rl") or 0)
              and (at("curriculum", m) or 0) < (at("curriculum", "cpg_rl") or 0)]  # fmt: skip
        def line(m):
            lv = at("curriculum", m)
            return f"{self.label(m)} {pct(at('success', m))}" + ("" if lv is None else f", level {lv:.1f}")

        text = (f"At {msteps(common)} env-steps (the shortest run's end), mean training success and curriculum level: " + "; ".join(line(m) for m in ("cpg_rl", *others)) + ".")
        self.add(claim, _word(len(ok), len(others)), text)

    def completes(self) -> None:
        rows = {t: by_m["cpg_rl"] for t, by_m in self.det.items() if "cpg_rl" in by_m}
        if not rows:
            return
        keys = [f"success_{d:g}m" for d in self.distances]
        lowest = {t: min(_mean(r, k) for k in keys) for t, r in rows.items()}
        word = HOLDS if all(v >= 1.0 for v in lowest.values()) else IN_PART if all(
            v >= self.levels["near"] for v in lowest.values()) else NOT
        last = keys[-1]
        text = "CPG_RL, deterministic action: " + "; ".join(
            f"{t} {_span(r, last)} at {self.distances[-1]:g} m (its lowest distance {pct(lowest[t])}), falls "
            f"{pct(_mean(r, 'fall_rate'))}" + (f", before the goal line {pct(_mean(r, 'fall_rate_before_goal'))}"
                                                if _mean(r, "fall_rate_before_goal") is not None else "")
            for t, r in rows.items()) + f". Holds in part means every distance at {pct(self.levels['near'])} or more."
        self.add("CPG_RL completes every task: 100 % at every distance on every terrain (Table 3)", word, text)

    def matches_paper(self, method: str, claim: str) -> None:
        """Each cell of ``method``'s deterministic row within ``paper_match`` of the paper's Table 3."""
        paper_key = "cpg" if method in ("cpg", "cpg_frame20") else method
        cells, off = 0, []
        for t, by_m in self.det.items():
            ref = self.res["paper_table3"].get(t, {}).get(paper_key)
            if method not in by_m or ref is None:
                continue
            for d, p in zip(self.distances, ref):
                v = _mean(by_m[method], f"success_{d:g}m")
                cells += 1
                if abs(v - p) > self.levels["paper_match"]:
                    off.append(f"{t} {d:g} m {pct(v)} against {pct(p)}")
        if not cells:
            return
        text = (f"{self.label(method)}, deterministic action, against the paper's row (within "
                f"{pct(self.levels['paper_match'])} of it): {cells - len(off)} of {cells} cells match"
                + (f"; apart: {'; '.join(off)}." if off else ".") + self.left_out(method, list(self.det)))
        self.add(claim, _word(cells - len(off), cells), text)

    def most_stable(self) -> None:
        walks, per_terrain, text = self.levels["walks"], [], []
        for t, by_m in self.det.items():
            if "cpg_rl" not in by_m:
                continue
            last = f"success_{self.distances[-1]:g}m"
            compared = [m for m, r in by_m.items() if m != "cpg_rl" and _mean(r, last) >= walks]
            skipped = [m for m in by_m if m != "cpg_rl" and m not in compared]
            me = by_m["cpg_rl"]
            above = [m for m in compared for k in ("pitch_var_deg2", "roll_var_deg2")
                     if _mean(by_m[m], k) <= _mean(me, k)]  # fmt: skip
            per_terrain.append(not above)
            line = (f"{t}: CPG_RL pitch / roll {deg2(_mean(me, 'pitch_var_deg2'))} / {deg2(_mean(me, 'roll_var_deg2'))}"
                    + "".join(f", {self.label(m)} {deg2(_mean(by_m[m], 'pitch_var_deg2'))} / "
                              f"{deg2(_mean(by_m[m], 'roll_var_deg2'))}" for m in compared))
            if skipped:
                line += " (not compared, below " + pct(walks) + " at " + f"{self.distances[-1]:g} m: " + ", ".join(
                    f"{self.label(m)} {pct(_mean(by_m[m], last))}" for m in skipped) + ")"
            text.append(line)
        if per_terrain:
            self.add("CPG_RL is the most stable method: the lowest pitch and roll variance (§3.3; deterministic "
                     "action, among the methods that walk the course; SAC- and TD3-CPG on skrl's untuned `scale` "
                     "preset, the task paper's row on its own physics and schedule)",
                     _word(sum(per_terrain), len(per_terrain)), "; ".join(text) + ".")

    def sampled_beats(self, method: str) -> None:
        """Pure DRL's sampled action against CPG_RL's on the blocks (rugged, complex) at the last distance."""
        last = f"success_{self.distances[-1]:g}m" if self.distances else None
        terrains = [t for t in ("rugged", "complex") if method in self.sampled.get(t, {}) and "cpg_rl" in
                    self.sampled.get(t, {})]  # fmt: skip
        if not terrains or last is None:
            return
        ok = [t for t in terrains if _mean(self.sampled[t][method], last) > _mean(self.sampled[t]["cpg_rl"], last)]
        text = "Sampled action: " + "; ".join(
            f"{t} {self.label(method)} {_span(self.sampled[t][method], last)} (pitch / roll "
            f"{deg2(_mean(self.sampled[t][method], 'pitch_var_deg2'))} / "
            f"{deg2(_mean(self.sampled[t][method], 'roll_var_deg2'))}) against CPG_RL "
            f"{_span(self.sampled[t]['cpg_rl'], last)} ({deg2(_mean(self.sampled[t]['cpg_rl'], 'pitch_var_deg2'))} / "
            f"{deg2(_mean(self.sampled[t]['cpg_rl'], 'roll_var_deg2'))})" for t in terrains) + "." \
            + self.last_checkpoint(method)
        self.add(f"{self.label(method)}'s sampled action, {ON[method] if method in ON else 'on its settings'}, walks "
                 f"the blocks further than CPG_RL's (rugged and complex ground, {self.distances[-1]:g} m)",
                 _word(len(ok), len(terrains)), text)

    def sac_above_td3(self) -> None:
        r = self.det.get("rugged", {})
        if "sac_cpg" not in r or "td3_cpg" not in r:
            return
        paper = self.res["paper_table3"]["rugged"]
        last = f"success_{self.distances[-1]:g}m"
        word = HOLDS if _mean(r["sac_cpg"], last) > _mean(r["td3_cpg"], last) else NOT
        self.add(f"SAC-CPG walks rugged ground further than TD3-CPG, both {ON['sac_cpg']} (the paper: "
                 f"{pct(paper['sac_cpg'][-1])} against {pct(paper['td3_cpg'][-1])} at {self.distances[-1]:g} m)", word,
                 f"Deterministic action at {self.distances[-1]:g} m: SAC-CPG {_span(r['sac_cpg'], last)}, TD3-CPG "
                 f"{_span(r['td3_cpg'], last)}." + self.left_out("sac_cpg", ["rugged"]))


def claims(res: dict, label) -> list[dict]:
    """The verdict of ``res`` (a comparison's ``results.json``): [{claim, verdict, text}, ...]; ``label`` names a
    method."""
    c = Claims(res, label)
    versus = f"{c.named('sac_cpg')} and {c.named('a2c_cpg')}"
    c.faster(("sac_cpg", "a2c_cpg"), f"CPG_RL converges faster than {versus} (Fig. 5a)")
    c.higher(("sac_cpg", "a2c_cpg"), f"CPG_RL converges higher than {versus} (Fig. 5a)")
    for m in ("joint", "joint_staged"):
        c.faster((m,), f"{c.named(m)} learns more slowly than CPG_RL (Fig. 5a)")
    c.completes()
    c.most_stable()
    for m in ("cpg", "cpg_frame20"):
        c.matches_paper(m, f"{label(m)} walks the blocks and fails on the stairs as the paper's fixed CPG does "
                           "(Table 3, every distance)")  # fmt: skip
    for m in ("sac_cpg", "td3_cpg"):
        c.matches_paper(m, f"{label(m)}'s row, {ON[m]}, matches the paper's (Table 3, every distance)")
    c.sac_above_td3()
    for m in ("joint", "joint_staged"):
        c.sampled_beats(m)
    return c.out


def tuning_markdown() -> list[str]:
    """The report's section ahead of the verdict: how each method's settings were chosen (:data:`TUNING`)."""
    return ["## Tuned and preset", "", "How each method's settings were chosen; a claim about a method that ran "
            "settings not chosen for it names them in the claim itself.", ""] + [
        f"- **{who}**: {what}" for who, what in TUNING]


def verdict_markdown(verdict: list[dict]) -> list[str]:
    """The report's verdict section, after :func:`tuning_markdown`'s."""
    lines = [*tuning_markdown(), "", "## Verdict", "", "Written by `studies/paper_comparison/compare.py` from `results.json` (`verdict`, and the numbers it "
             "reads: `table3`, `fig5a`, `paper_table3`, `verdict_levels`), claim by claim:", ""]  # fmt: skip
    return lines + [f"- **{v['claim']}: {v['verdict']}.** {v['text']}" for v in verdict]
