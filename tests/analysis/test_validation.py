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
