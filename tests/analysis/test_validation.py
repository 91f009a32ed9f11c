"""Deterministic validation's candidates and choice (hexnewton.analysis.validation); the validation itself runs in
train.py's tests (tests/learning/test_train.py)."""

from hexnewton.analysis.validation import Candidate, candidates, choose, report_lines


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


def test_choice_goal_first_then_3m_then_falls_then_the_later():
    cands = [Candidate(it, f"model_{it}.pt", "saved") for it in (100, 150, 200)]
    r = [{"goal": 1.0, "walk_3m": 1.0, "fell": 0.0, "off_course": 0.0},
         {"goal": 0.0, "walk_3m": 1.0, "fell": 0.0, "off_course": 1.0},  # walks 3 m, passes beside the goal
         {"goal": 1.0, "walk_3m": 1.0, "fell": 0.0, "off_course": 0.0}]  # fmt: skip
    assert choose(cands, r) == 2  # a tie goes to the later checkpoint
    r[2] = dict(r[2], fell=0.1)
    assert choose(cands, r) == 0
    lines = report_lines(cands, r, 0)
    assert lines[0].startswith("  -> model_100.pt (saved, iteration 100): goal 100.0 %") and "off course 100.0 %" in lines[1]


def test_validation_on_several_courses_averages_each_candidates_shares(monkeypatch):
    """``--agent.validation_terrains rugged complex``: each course validated one after another, each candidate judged
    on its shares averaged over them, each course's own results kept; the flag parses and checks its names."""
    import pytest

    from hexnewton.analysis import validation
    from hexnewton.apps.train import configs, parser
    from hexnewton.tasks import task

    per = {"rugged": [{"goal": 0.9, "walk_3m": 1.0, "fell": 0.1, "off_course": 0.0, "rounds": 8},
                      {"goal": 1.0, "walk_3m": 1.0, "fell": 0.0, "off_course": 0.0, "rounds": 8}],
           "complex": [{"goal": 1.0, "walk_3m": 1.0, "fell": 0.0, "off_course": 0.0, "rounds": 8},
                       {"goal": 0.8, "walk_3m": 0.9, "fell": 0.0, "off_course": 0.2, "rounds": 8}]}  # fmt: skip
    seen = []

    def fake(cands, controller, terrain, rounds, device, max_steps, goal_distance=None):
        seen.append(terrain)
        return per[terrain]

    monkeypatch.setattr(validation, "validate", fake)
    cands = [Candidate(it, f"model_{it}.pt", "saved") for it in (250, 299)]
    mean, got = validation.validate_courses(cands, "cpg_rl", ["rugged", "complex"], 8, "cpu", 30)
    assert seen == ["rugged", "complex"] and got == per
    assert mean[0] == {"goal": 0.95, "walk_3m": 1.0, "fell": 0.05, "off_course": 0.0, "rounds": 16}
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
