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
                f"stays there for {msteps(self.levels['window_env_steps'])} from {msteps(c['sustained'])} on"
                if c["sustained"] is not None else f"never stays there for {msteps(self.levels['window_env_steps'])}")
        if c.get("dip_after_first") and c["dip_after_first"]["value"] < level:
            s += f" (after the first crossing it falls to {pct(c['dip_after_first']['value'])} at " \
                 f"{msteps(c['dip_after_first']['at'])})"  # fmt: skip
        return s + f", peaks at {pct(c['peak']['value'])} ({msteps(c['peak']['at'])}) and ends at " \
                   f"{pct(c['end']['value'])} ({msteps(c['end']['at'])})"  # fmt: skip

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
                + (f"; apart: {'; '.join(off)}." if off else "."))
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
                     "action, among the methods that walk the course)", _word(sum(per_terrain), len(per_terrain)),
                     "; ".join(text) + ".")

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
            f"{deg2(_mean(self.sampled[t]['cpg_rl'], 'roll_var_deg2'))})" for t in terrains) + "."
        self.add(f"{self.label(method)}'s sampled action walks the blocks further than CPG_RL's (rugged and complex "
                 f"ground, {self.distances[-1]:g} m)", _word(len(ok), len(terrains)), text)

    def sac_above_td3(self) -> None:
        r = self.det.get("rugged", {})
        if "sac_cpg" not in r or "td3_cpg" not in r:
            return
        paper = self.res["paper_table3"]["rugged"]
        last = f"success_{self.distances[-1]:g}m"
        word = HOLDS if _mean(r["sac_cpg"], last) > _mean(r["td3_cpg"], last) else NOT
        self.add(f"SAC-CPG walks rugged ground further than TD3-CPG (the paper: {pct(paper['sac_cpg'][-1])} against "
                 f"{pct(paper['td3_cpg'][-1])} at {self.distances[-1]:g} m)", word,
                 f"Deterministic action at {self.distances[-1]:g} m: SAC-CPG {_span(r['sac_cpg'], last)}, TD3-CPG "
                 f"{_span(r['td3_cpg'], last)}.")


def claims(res: dict, label) -> list[dict]:
    """The verdict of ``res`` (a comparison's ``results.json``): [{claim, verdict, text}, ...]; ``label`` names a
    method."""
    c = Claims(res, label)
    c.faster(("sac_cpg", "a2c_cpg"), "CPG_RL converges faster than SAC-CPG and A2C-CPG (Fig. 5a)")
    c.higher(("sac_cpg", "a2c_cpg"), "CPG_RL converges higher than SAC-CPG and A2C-CPG (Fig. 5a)")
    for m in ("joint", "joint_staged"):
        c.faster((m,), f"{label(m)} learns more slowly than CPG_RL (Fig. 5a)")
    c.completes()
    c.most_stable()
    for m in ("cpg", "cpg_frame20"):
        c.matches_paper(m, f"{label(m)} walks the blocks and fails on the stairs as the paper's fixed CPG does "
                           "(Table 3, every distance)")  # fmt: skip
    for m in ("sac_cpg", "td3_cpg"):
        c.matches_paper(m, f"{label(m)}'s row matches the paper's (Table 3, every distance)")
    c.sac_above_td3()
    for m in ("joint", "joint_staged"):
        c.sampled_beats(m)
    return c.out


def verdict_markdown(verdict: list[dict]) -> list[str]:
    """The report's verdict section."""
    lines = ["## Verdict", "", "Written by `studies/paper_comparison/compare.py` from `results.json` (`verdict`, and the numbers it "
             "reads: `table3`, `fig5a`, `paper_table3`, `verdict_levels`), claim by claim:", ""]  # fmt: skip
    return lines + [f"- **{v['claim']}: {v['verdict']}.** {v['text']}" for v in verdict]
