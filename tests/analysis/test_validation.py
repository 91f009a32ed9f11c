"""Deterministic validation's candidates and choice (hexnewton.analysis.validation); the validation itself runs in
train.py's tests (tests/learning/test_train.py)."""

import numpy as np
import pytest

from hexnewton.analysis.validation import (Candidate, candidate_rows, candidate_variances, candidates, choose,
                                           report_lines, validation_share)


def test_candidates_are_the_last_stage_newest_first_and_the_kept_ones(tmp_path):
    for it in (0, 50, 100, 150, 200, 250, 299):
        (tmp_path / f"model_{it}.pt").write_bytes(b"")
    (tmp_path / "model_best.pt").write_bytes(b"")
    last = Candidate(299, str(tmp_path / "model_299.pt"), "last")
    best = Candidate(230, str(tmp_path / "model_best.pt"), "best training success 0.950")
    got = candidates(str(tmp_path), 200, last, best, 4)
    assert [(c.iteration, c.why) for c in got] == [(200, "saved"), (230, "best training success 0.950"),
                                                   (250, "saved"), (299, "last")]  # fmt: skip
    # the last stage began at 260: nothing saved before it; no best kept
    assert [c.iteration for c in candidates(str(tmp_path), 260, last, None, 4)] == [299]
    # the best is the last iteration: one candidate for both
    assert [c.iteration for c in candidates(str(tmp_path), 250, last, Candidate(299, "b", "best"), 3)] == [250, 299]


def test_choice_goal_first_then_falls_before_the_goal_then_the_later():
    """Goals first, then the falls before the goal line; falls past it (off the patch's end, a steering miss) and the
    3 m walks do not weigh; total falls are reported beside."""
    cands = [Candidate(it, f"model_{it}.pt", "saved") for it in (100, 150, 200)]
    var = {"pitch_var": 20.0, "roll_var": 8.0}
    r = [{"goal": 1.0, "walk_3m": 1.0, "fell": 0.0, "fell_before_goal": 0.0, "off_course": 0.0, **var},
         {"goal": 0.0, "walk_3m": 1.0, "fell": 0.0, "fell_before_goal": 0.0, "off_course": 1.0, **var},  # beside it
         {"goal": 1.0, "walk_3m": 1.0, "fell": 0.0, "fell_before_goal": 0.0, "off_course": 0.0, **var}]  # fmt: skip
    assert choose(cands, r) == 2  # a tie goes to the later checkpoint
    r[2] = dict(r[2], fell=0.3)  # falls past the goal line only
    assert choose(cands, r) == 2
    r[2] = dict(r[2], fell_before_goal=0.1)
    assert choose(cands, r) == 0
    r[0] = dict(r[0], walk_3m=0.5, fell=0.5)  # fewer 3 m walks and more falls, none before the goal line
    assert choose(cands, r) == 0
    assert choose(cands, [dict(x, pitch_var=99.0) if i == 0 else x for i, x in enumerate(r)]) == 0  # not weighed
    lines = report_lines(cands, r, 2)
    assert lines[2].startswith("  -> model_200.pt (saved, iteration 200): goal 100.0 %, fell before the goal 10.0 % "
                               "(in all 30.0 %), 3 m 100.0 %") and "off course 100.0 %" in lines[1]
    assert lines[0].endswith("off course 0.0 %, pitch / roll var 20.0 / 8.0 deg²")


def test_each_candidates_variance_is_over_its_own_rounds_first_episodes():
    """Random angles, 3 candidates interleaved over 12 robots, episodes of random lengths, a few non-finite angles:
    each candidate's variance equals the one over its own robots' steps in their first episode (float64 reference)."""
    rng = np.random.default_rng(0)
    t, n, k = 40, 12, 3
    rpy = rng.normal(0.0, 0.2, (t, n, 3))
    rpy[5, 4, 1] = np.nan
    in_episode = np.arange(t)[:, None] < rng.integers(1, t + 1, n)[None, :]
    pitch, roll = candidate_variances(rpy.astype(np.float32), in_episode, candidate_rows(n, k))
    for i in range(k):
        for axis, got in ((1, pitch[i]), (0, roll[i])):
            ref = [np.degrees(rpy[s, e, axis]) for e in range(i, n, k) for s in range(t)
                   if in_episode[s, e] and np.isfinite(rpy[s, e, axis])]  # fmt: skip
            assert np.isclose(got, np.var(ref), rtol=1e-5)
    assert np.isnan(candidate_variances(rpy, np.zeros((t, n), bool), candidate_rows(n, k))[0][0])


def test_validation_on_several_courses_averages_each_candidates_shares(monkeypatch):
    """``--agent.validation_terrains rugged complex``: each course validated one after another, each candidate judged
    on its shares averaged over them, each course's own results kept; the flag parses and checks its names."""
    import pytest

    from hexnewton.analysis import validation
    from hexnewton.apps.train import configs, parser
    from hexnewton.tasks import task

    var = {"pitch_var": 20.0, "roll_var": 8.0}
    per = {"rugged": [{"goal": 0.9, "walk_3m": 1.0, "fell": 0.1, "fell_before_goal": 0.1, "off_course": 0.0, **var,
                       "rounds": 8},
                      {"goal": 1.0, "walk_3m": 1.0, "fell": 0.0, "fell_before_goal": 0.0, "off_course": 0.0, **var,
                       "rounds": 8}],
           "complex": [{"goal": 1.0, "walk_3m": 1.0, "fell": 0.0, "fell_before_goal": 0.0, "off_course": 0.0,
                        "pitch_var": 30.0, "roll_var": 10.0, "rounds": 8},
                       {"goal": 0.8, "walk_3m": 0.9, "fell": 0.0, "fell_before_goal": 0.0, "off_course": 0.2, **var,
                        "rounds": 8}]}  # fmt: skip
    seen = []

    def fake(cands, controller, terrain, rounds, device, max_steps, goal_distance=None):
        seen.append(terrain)
        return per[terrain]

    monkeypatch.setattr(validation, "validate", fake)
    cands = [Candidate(it, f"model_{it}.pt", "saved") for it in (250, 299)]
    terrains = ["rugged", "complex"]  # one process: every (course, candidate) pair, course by course
    mean, got = validation.combine_courses(cands, terrains, validation.validate_share(cands, "cpg_rl", terrains, 8,
                                                                                      "cpu", 30))  # fmt: skip
    assert seen == ["rugged", "complex"] and got == per
    assert mean[0] == {"goal": 0.95, "walk_3m": 1.0, "fell": 0.05, "fell_before_goal": 0.05, "off_course": 0.0,
                       "pitch_var": 25.0, "roll_var": 9.0, "rounds": 16}
    assert mean[1]["goal"] == 0.9 and choose(cands, mean) == 0
    assert validation.course_names(["complex"]) == "the complex course"
    assert validation.course_names(["rugged", "stepped", "complex"]) == "the rugged, stepped and complex courses"

    base = task("complex")
    args = parser(base, False).parse_args(["--task", "complex", "--agent.validation_terrains", "rugged", "complex"])
    assert configs(args, base, None)[1].validation_terrains == ("rugged", "complex")
    with pytest.raises(SystemExit):  # argparse: one line naming the choices, exit 2
        parser(base, False).parse_args(["--agent.validation_terrains", "moon"])
    from hexnewton.learning.agent import AgentConfig

    with pytest.raises(ValueError, match="agent.validation_terrains: moon is not one of"):
        AgentConfig(validation_terrains=("moon",)).check()
    with pytest.raises(ValueError, match="name each course once"):
        AgentConfig(validation_terrains=("rugged", "rugged")).check()


def test_the_ranks_shares_cover_every_course_and_candidate_once():
    """Under torchrun each rank validates a share (whole courses while there are no more ranks than courses, else a
    course's candidates dealt over its ranks); together the shares hold every (course, candidate) pair once, and no
    rank steps more envs than the pairs need."""
    for k, courses, world in [(4, 1, 1), (4, 1, 4), (4, 1, 6), (4, 3, 2), (4, 3, 3), (4, 3, 4), (6, 3, 8), (3, 2, 5)]:
        shares = [validation_share(k, courses, r, world) for r in range(world)]
        pairs = sorted((c, i) for share in shares for c, idx in share.items() for i in idx)
        assert pairs == [(c, i) for c in range(courses) for i in range(k)], (k, courses, world)
        assert max(len(share) for share in shares) == -(-courses // world)
    assert validation_share(4, 1, 0, 4) == {0: [0]} and validation_share(4, 1, 5, 6) == {}
    assert validation_share(4, 3, 3, 4) == {0: [1, 3]}


def test_shared_validation_gives_what_one_process_gives(monkeypatch):
    """The results of every rank's share, combined, are those of one process validating everything (with a stand-in
    validation whose result depends only on the course and the candidate)."""
    from hexnewton.analysis import validation

    def fake(cands, controller, terrain, rounds, device, max_steps, goal_distance=None):
        return [{"goal": 0.1 * c.iteration + (terrain == "rugged"), "walk_3m": 1.0, "fell": 0.0,
                 "fell_before_goal": 0.0, "off_course": 0.0, "pitch_var": 1.0, "roll_var": 2.0, "rounds": rounds}
                for c in cands]  # fmt: skip

    monkeypatch.setattr(validation, "validate", fake)
    cands = [Candidate(it, f"model_{it}.pt", "saved") for it in (1, 2, 3, 4)]
    terrains = ["rugged", "stepped", "complex"]
    one = validation.combine_courses(cands, terrains,
                                     validation.validate_share(cands, "cpg_rl", terrains, 8, "cpu", 30))
    for world in (2, 4, 8):
        merged = {}
        for r in range(world):
            merged.update(validation.validate_share(cands, "cpg_rl", terrains, 8, "cpu", 30, None, r, world))
        assert validation.combine_courses(cands, terrains, merged) == one


def test_courses_side_by_side_are_each_course_in_its_own_lane_group():
    """``validation_together``'s env: one lane group per course, each group's one lane the course's patch at its full
    height (the course as ``evaluate`` builds it, with the group's block seed), a flat course never leading (a ground
    plane); the robots spread evenly over the courses."""
    from dataclasses import replace

    from hexnewton.analysis.validation import VALIDATION_SEED, together_config
    from hexnewton.config import HexConfig
    from hexnewton.terrain.heightmap import build_height_grid, env_groups, lane_config
    from hexnewton.tasks import course

    names = ["flat", "rugged", "stepped", "complex"]
    cfg, order = together_config(names, HexConfig(), 6, "cpu")
    assert [names[c] for c in order] == ["rugged", "stepped", "complex", "flat"]
    assert cfg.sim.num_envs == 24 and cfg.terrain.levels == 1 and not cfg.randomization.enabled
    assert np.bincount(env_groups(cfg.terrain, cfg.sim.num_envs)).tolist() == [6, 6, 6, 6]
    for g, c in enumerate(order):
        lane = lane_config(cfg.terrain, 0, g)
        alone = course(names[c], None, None, 8, "cpu", VALIDATION_SEED).terrain
        if names[c] != "flat":
            assert np.array_equal(build_height_grid(lane).heights,
                                  build_height_grid(replace(alone, seed=lane.seed)).heights), names[c]  # fmt: skip
        assert (lane.name, lane.width, lane.rugged_half_width, lane.x_max) == \
            (alone.name, alone.width, alone.rugged_half_width, alone.x_max)  # fmt: skip
    with pytest.raises(ValueError, match="other than flat"):
        together_config(["flat"], HexConfig(), 2, "cpu")


def test_courses_side_by_side_give_every_course_and_candidate_its_rounds(monkeypatch):
    """``validate_share(..., together=True)`` in one process: one env, robot i on course i mod G driven by candidate
    (i // G) mod K, ``rounds`` robots per (course, candidate) pair, the results keyed by the courses' own order; under
    torchrun, or with one course, course by course as before."""
    from hexnewton.analysis import validation
    from hexnewton.terrain.heightmap import env_groups

    seen = {}

    def walk(cfg, controller, cands, rows, max_steps, where, results=None):
        seen.update(cfg=cfg, rows=rows, results=results, where=where)
        return [{"goal": float(i)} for i in range(len(results))]

    monkeypatch.setattr(validation, "_walk", walk)
    monkeypatch.setattr(validation, "validate", lambda cands, *a, **k: [{"goal": -1.0} for _ in cands])
    cands = [Candidate(it, "results/policies/cpg_rl_complex.pt", "saved") for it in (1, 2, 3, 4)]
    names = ["flat", "rugged", "complex"]
    got = validation.validate_share(cands, "cpg_rl", names, 5, "cpu", 30, together=True)
    n = seen["cfg"].sim.num_envs
    groups = env_groups(seen["cfg"].terrain, n)
    assert n == 60 and sorted(np.concatenate(seen["results"]).tolist()) == list(range(n))
    assert "rugged, complex and flat courses side by side, 5 rounds each" in seen["where"]
    for j, rows in enumerate(seen["results"]):
        g, c = divmod(j, 4)
        assert rows.size == 5 and (groups[rows] == g).all() and np.isin(rows, seen["rows"][c]).all()
    # group 0 is rugged (names index 1), group 2 flat (index 0)
    assert got[(1, 0)]["goal"] == 0.0 and got[(0, 3)]["goal"] == 11.0 and len(got) == 12
    assert validation.validate_share(cands, "cpg_rl", names, 5, "cpu", 30, None, 0, 3, True)[(0, 0)]["goal"] == -1.0
    assert validation.validate_share(cands, "cpg_rl", ["rugged"], 5, "cpu", 30, together=True)[(0, 0)]["goal"] == -1
    # a navigate run's validation (random goals) stays course by course
    nav = [Candidate(1, "results/policies/cpg_rl_navigate_flat.pt", "saved")]
    seen.clear()
    assert validation.validate_share(nav, "cpg_rl", names, 5, "cpu", 30, together=True) == \
        {(c, 0): {"goal": -1.0} for c in range(3)} and not seen  # fmt: skip


@pytest.mark.slow  # end to end: ~20 s on a 2-core CPU
def test_courses_side_by_side_walk_each_course():
    """The shipped policy on the rugged and stepped courses side by side, 2 rounds each: its robots on the stepped
    course start on its flat run-up, those on the rugged course on blocks (body angles vary more)."""
    from hexnewton.analysis.validation import validate_together

    cands = [Candidate(1, "results/policies/cpg_rl_complex.pt", "shipped")]
    got = validate_together(cands, "cpg_rl", ["stepped", "rugged"], 2, "cpu", 40)
    assert sorted(got) == [(0, 0), (1, 0)] and all(r["rounds"] == 2 and r["fell"] == 0.0 for r in got.values())
    assert got[(1, 0)]["pitch_var"] > got[(0, 0)]["pitch_var"]


def test_choose_worst_course_with_falls_weighted():
    """``validation_rank worst``: the worst informative course's goal share less 2 x its falls before the goal line
    decides; a course every candidate walks whole (stepped here) does not count; "mean" keeps the averaged shares."""
    cands = [Candidate(100 + i, f"model_{100 + i}.pt", "saved") for i in range(3)]
    row = lambda goal, fell: {"goal": goal, "fell_before_goal": fell}  # noqa: E731
    per = {"rugged": [row(0.99, 0.010), row(0.97, 0.002), row(0.98, 0.000)],
           "stepped": [row(1.0, 0.0), row(1.0, 0.0), row(1.0, 0.0)],
           "complex": [row(0.99, 0.0), row(0.99, 0.0), row(0.975, 0.0)]}
    mean = [{k: float(np.mean([per[t][i][k] for t in per])) for k in ("goal", "fell_before_goal")} for i in range(3)]
    assert choose(cands, mean) == 0  # the most goals on average, its falls a tie-break only
    # worst course: 0.99 - 0.02 = 0.970, 0.97 - 0.004 = 0.966, min(0.98, 0.975) = 0.975
    assert choose(cands, mean, per, "worst", 2.0) == 2
    assert choose(cands, mean, per, "worst", 0.0) == 0  # without the weight: 0.99 on its worst course
    with pytest.raises(ValueError, match="validation rank"):
        choose(cands, mean, None, "worst")
