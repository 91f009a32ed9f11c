"""The navigate study's results: each task's training run, its navigation evaluation and its bundle in C MuJoCo, kept
in this folder and rendered as report.md and results.json.

    python studies/navigate/build.py --add DIR [--revision REV]   # a lease's queue outputs (queue.sh's $NAV, unpacked)
    python studies/navigate/build.py video flat                   # the square's video of the kept policy (CPU, EGL)
    python studies/navigate/build.py                              # report.md, results.json from what the study keeps

``--add`` takes from DIR what ``queue.sh`` leaves for a task T (flat, rugged): ``train_T.log`` (``train.py``'s console),
``keep/navigate_T.pt`` (the result, kept here as its policy alone: runs/T/policy.pt), ``keep/timing_T.json``,
``eval_T/`` (``evaluate --navigate``: report.md, results.json, the paths' figure; kept as eval/T/) and ``s2s_T/``
(``sim2sim --waypoints``; kept as sim2sim/T/). A task whose evaluation is missing stays partial in the report. A
variant (:data:`VARIANTS`: a task trained with other flags) is kept as runs/NAME/, eval/NAME/ alike.
"""

from __future__ import annotations

import argparse
import glob
import json
import os
import re
import shutil
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
TASKS = ("flat", "rugged")
#: kept runs of a task with other settings than the task's, shown beside it and never among its targets: name ->
#: (terrain, the flags that give it, what they change). rugged-20s: the training episode and budget of flat ground on
#: the blocks, where a 20 s episode reaches 0.31 goals (docs/training.md, "Walking to any goal")
VARIANTS = {"rugged-20s": ("rugged", "--env.task.max_episode_steps 1000 --agent.max_minutes 6.5",
                           "20 s training episodes, 6.5 min of training")}
#: the bundle in C MuJoCo against Newton on the same square: within this many points of completed rounds
SIM2SIM_POINTS = 5.0
#: the square's video: the kept policy on the 2 m square, three robots, 500 frames: on flat ground 20 s of control,
#: every second step drawn; on the blocks, where the robot walks the square in ~80-100 s, 90 s, every ninth step drawn
VIDEO_ARGS = {"flat": "--waypoints 2,0 2,2 0,2 0,0 --num_envs 3 --steps 1000 --video_speed 2 --headless",
              "rugged": "--waypoints 2,0 2,2 0,2 0,0 --num_envs 3 --steps 4500 --video_speed 9 --headless"}
#: the video re-encoded for size (results/videos/report.md does the same); the blocks' texture keeps 500 frames at
#: 5 MB, so the rugged video is encoded once more at 640 x 360 (1.2 MB)
ENCODE = ["-c:v", "libx264", "-crf", "32", "-preset", "slow", "-pix_fmt", "yuv420p"]
SHRINK = {"rugged": ["-vf", "scale=640:-2", "-c:v", "libx264", "-crf", "37", "-preset", "slow", "-pix_fmt", "yuv420p"]}


def parse_train_log(text: str) -> dict:
    """What ``train.py`` printed: the task, envs and device, the start-up, why training stopped, the iterations, the
    goals reached per episode in its last episodes, the validation's candidates and choice, and the seconds from process
    start to the exported result."""
    out: dict = {"candidates": []}
    for line in text.splitlines():
        if m := re.match(r"training task (\S+): (\d+) envs on (\S+), (\d+) iterations", line):
            out.update(task=m[1], num_envs=int(m[2]), device=m[3], max_iterations=int(m[4]))
        elif m := re.match(r"start-up ([\d.]+) s from process start", line):
            out["startup_s"] = float(m[1])
        elif m := re.match(r"finished at iteration (\d+) after (\d+) s \((.+)\)", line):
            out.update(last_iteration=int(m[1]), train_s=float(m[2]), stopped_by=m[3])
        elif m := re.match(r"\s+(->)?\s*(\S+\.pt) \((.+), iteration (\d+)\): goal ([\d.]+) %, fell before the goal "
                           r"([\d.]+) %", line):  # fmt: skip
            out["candidates"].append(dict(checkpoint=m[2], why=m[3], iteration=int(m[4]), goal=float(m[5]) / 100,
                                          fell_before_goal=float(m[6]) / 100, chosen=bool(m[1])))  # fmt: skip
        elif m := re.match(r"deterministic validation, (\d+) rounds of the (\S+) course .* per candidate, (\d+) s", line):
            out.update(validation_rounds=int(m[1]), validation_s=float(m[3]))
        elif m := re.match(r"last episodes: .*goals_reached ([\d.]+), episodes (\d+)", line):
            out.update(goals_per_episode=float(m[1]), last_episodes=int(m[2]))
        elif m := re.match(r"(\d+) s from process start to the exported result", line):
            out["wall_s_to_result"] = float(m[1])
    return out


def _terrain(t: str) -> str:
    """The terrain of a kept run: a task's own name, or a variant's terrain."""
    return VARIANTS[t][0] if t in VARIANTS else t


def _note_lease(dst: str, lease: str, revision: str | None) -> None:
    """lease.json beside what was kept in ``dst``: the commit the lease ran and the lease's folder name."""
    with open(os.path.join(dst, "lease.json"), "w") as f:
        json.dump({"revision": revision, "lease": os.path.basename(os.path.normpath(lease))}, f, indent=1)


def add(lease: str, revision: str | None) -> list[str]:
    """Copy a lease's navigate outputs into the study; returns the tasks whose files were taken."""
    from hexnewton.learning.checkpoint import save_policy_only

    taken = []
    for t in TASKS:
        got = False
        log, ckpt = os.path.join(lease, f"train_{t}.log"), os.path.join(lease, "keep", f"navigate_{t}.pt")
        if os.path.exists(log) and os.path.exists(ckpt):
            info = parse_train_log(open(log).read())
            if not info.get("task"):
                raise ValueError(f"{log}: not train.py's console (no 'training task' line)")
            dst = os.path.join(HERE, "runs", t)
            os.makedirs(dst, exist_ok=True)
            shutil.copyfile(log, os.path.join(dst, "train.log"))
            timing = os.path.join(lease, "keep", f"timing_{t}.json")
            if os.path.exists(timing):
                shutil.copyfile(timing, os.path.join(dst, "timing.json"))
            policy = os.path.join(dst, "policy.pt")
            if os.path.islink(policy):  # the kept policy is a shipped one (runs/flat): the link goes, the file stays
                os.remove(policy)
            save_policy_only(ckpt, policy)
            _note_lease(dst, lease, revision)
            got = True
        for src, kind in ((f"eval_{t}", "eval"), (f"s2s_{t}", "sim2sim")):
            folder = os.path.join(lease, src)
            if os.path.exists(os.path.join(folder, "results.json")):
                dst = os.path.join(HERE, kind, t)
                shutil.rmtree(dst, ignore_errors=True)
                os.makedirs(dst)
                for f in glob.glob(os.path.join(folder, "*")):
                    if f.endswith((".md", ".json", ".png")):
                        shutil.copyfile(f, os.path.join(dst, os.path.basename(f)))
                _note_lease(dst, lease, revision)
                got = True
        if got:
            taken.append(t)
    if not taken:
        raise ValueError(f"{lease}: no navigate outputs (train_flat.log with keep/navigate_flat.pt, eval_flat/, ...)")
    return taken


def video(t: str) -> dict:
    """The kept policy of task ``t`` on the 2 m square through ``play.py --headless --video`` (ViewerGL through EGL),
    re-encoded for size into media/square_T.mp4; its command, wall time and play.py's summary in media/videos.json."""
    import imageio_ffmpeg

    policy = os.path.join("studies", "navigate", "runs", t, "policy.pt")
    root = os.path.dirname(os.path.dirname(HERE))
    if not os.path.exists(os.path.join(root, policy)):
        raise ValueError(f"no {policy}: python studies/house/kept.py fetch {policy} (or a lease's: --add DIR)")
    media = os.path.join(HERE, "media")
    os.makedirs(media, exist_ok=True)
    raw, out = os.path.join(media, f".square_{t}_raw.mp4"), os.path.join(media, f"square_{t}.mp4")
    command = f"python play.py --checkpoint {policy} {VIDEO_ARGS[t]} --video out.mp4"
    t0 = time.time()
    done = subprocess.run([sys.executable, "play.py", "--checkpoint", policy, *VIDEO_ARGS[t].split(), "--video", raw,
                           "--no-progress"], cwd=root, capture_output=True, text=True,
                          env=dict(os.environ, MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl")))  # fmt: skip
    wall = time.time() - t0
    if done.returncode:
        raise RuntimeError(f"play.py failed: {(done.stderr or done.stdout).strip().splitlines()[-1]}")
    ffmpeg = [imageio_ffmpeg.get_ffmpeg_exe(), "-y", "-loglevel", "error", "-i"]
    subprocess.run([*ffmpeg, raw, *ENCODE, out], check=True)
    encoded = "ffmpeg " + " ".join(ENCODE)
    if t in SHRINK:
        subprocess.run([*ffmpeg, out, *SHRINK[t], raw + ".mp4"], check=True)
        os.replace(raw + ".mp4", out)
        encoded += ", then ffmpeg " + " ".join(SHRINK[t])
    os.remove(raw)
    printed = [line for line in done.stdout.splitlines() if line.startswith(("[", "  |"))]  # the rollout's summary
    path = os.path.join(media, "videos.json")
    videos = json.load(open(path)) if os.path.exists(path) else {}
    videos[t] = {"command": command, "wall_s": round(wall, 1), "printed": printed,
                 "machine": f"{os.cpu_count()} CPU cores, device cpu, EGL", "encoded": encoded}
    with open(path, "w") as f:
        json.dump(videos, f, indent=1)
    return videos[t]


def load() -> dict:
    """Everything the study keeps, as results.json holds it."""
    from hexnewton.analysis.navigation import target_checks

    res: dict = {"training": {}, "evaluation": {}, "sim2sim": {}, "targets": [], "partial": [], "variants": {}}
    for t in (*TASKS, *VARIANTS):
        terrain = _terrain(t)
        run = os.path.join(HERE, "runs", t)
        if os.path.exists(os.path.join(run, "train.log")):
            info = parse_train_log(open(os.path.join(run, "train.log")).read())
            for name in ("timing.json", "lease.json"):
                if os.path.exists(os.path.join(run, name)):
                    with open(os.path.join(run, name)) as f:
                        d = json.load(f)
                    if name == "timing.json":
                        info.update(device_name=d.get("device_name"), env_steps=d.get("env_steps"),
                                    first_iteration_s=d.get("first_iteration_s"))  # fmt: skip
                    else:
                        info["revision"] = d.get("revision")
            res["training"][t] = info
        ev = os.path.join(HERE, "eval", t, "results.json")
        if os.path.exists(ev):
            with open(ev) as f:
                d = json.load(f)
            r = d["results"][terrain]["cpg_rl"]
            meta = d["meta"]
            limits = meta["max_steps (goal, square)"]  # per terrain, or one pair for every terrain
            lease = os.path.join(HERE, "eval", t, "lease.json")
            revision = json.load(open(lease)).get("revision") if os.path.exists(lease) else None
            res["evaluation"][t] = {"command": meta["command"], "rounds": meta["rounds per bearing and of the square"],
                                    "max_steps": limits[terrain] if isinstance(limits, dict) else limits,
                                    "revision": revision,
                                    "bearings": r["bearings"], "square": r["square"]}  # fmt: skip
            checks = target_checks({terrain: {"cpg_rl": r}})
            if t in VARIANTS:
                res["variants"][t] = {"terrain": terrain, "flags": VARIANTS[t][1], "changes": VARIANTS[t][2],
                                      "targets": checks}  # fmt: skip
            else:
                res["targets"] += checks
        if t in VARIANTS:  # beside its task: no bundle in C MuJoCo, nothing partial
            continue
        s2s = os.path.join(HERE, "sim2sim", t, "results.json")
        if os.path.exists(s2s) and t in res["evaluation"]:
            with open(s2s) as f:
                mj = json.load(f)[t]
            newton = res["evaluation"][t]["square"]
            diff = 100 * abs(mj["completed"] - newton["completed"])
            res["sim2sim"][t] = {"mujoco": mj, "newton": {k: newton[k] for k in mj if k in newton},
                                 "points_apart": round(diff, 2), "within": diff <= SIM2SIM_POINTS}  # fmt: skip
            if t == "flat":
                res["targets"].append(dict(terrain=t, controller="cpg_rl", what="the bundle in C MuJoCo: square "
                                           "completed, points from Newton's", got=diff, need=SIM2SIM_POINTS,
                                           at_least=False, met=diff <= SIM2SIM_POINTS, unit="points"))  # fmt: skip
        for what, have in (("training", t in res["training"]), ("evaluation", t in res["evaluation"]),
                           ("sim2sim", t != "flat" or t in res["sim2sim"])):  # fmt: skip
            if not have:
                res["partial"].append(f"navigate-{t}: {what}")
    videos = os.path.join(HERE, "media", "videos.json")
    res["videos"] = json.load(open(videos)) if os.path.exists(videos) else {}
    return res


def _num(v: float | None) -> str:
    return "-" if v is None else f"{v:.2f}"


def _pct(v: float | None) -> str:
    return "-" if v is None else f"{100 * v:.1f} %"


def _target_line(c: dict) -> str:
    rel = ">=" if c["at_least"] else "<="
    got, need = ((f"{c['got']:.1f}", f"{c['need']:g}") if c.get("unit") == "points"
                 else (_pct(c["got"]), f"{100 * c['need']:g} %"))  # fmt: skip
    return f"- navigate-{c['terrain']}: {c['what']} {got} ({rel} {need}): **{'met' if c['met'] else 'not met'}**"


def _label(t: str) -> tuple[str, str]:
    """A kept run's flags after ``--task`` (a variant's) and its name in the tables."""
    if t in VARIANTS:
        return " " + VARIANTS[t][1], f"navigate-{_terrain(t)}, {VARIANTS[t][2]}"
    return "", f"navigate-{t}"


def _figure(t: str) -> str:
    """evaluate's top view of the paths, named for the terrain."""
    return f"fig_paths_{_terrain(t)}_cpg_rl.png"


def render(res: dict) -> str:
    from hexnewton.config import TaskConfig

    dt = TaskConfig().control_dt  # the evaluation's limits are in control steps
    lines = ["# Walking to any goal: navigate-flat and navigate-rugged", "",
             "`python studies/navigate/build.py` renders this report and results.json from what the study keeps: each "
             "task's training run (runs/T/: train.py's console, timing.json, the result's policy), its navigation "
             "evaluation (eval/T/: `python -m hexnewton.apps.evaluate --navigate`, 1000 unseen rounds per bearing and "
             "1000 of the square, deterministic action, the test seeds) and its bundle in C MuJoCo (sim2sim/T/). "
             "studies/navigate/README.md has the commands.", ""]  # fmt: skip
    if res["partial"]:
        lines += ["**Partial**: not measured yet: " + "; ".join(res["partial"]) + ".", ""]
    lines += ["## Targets", ""] + [_target_line(c) for c in res["targets"]]
    for name, v in res["variants"].items():
        lines += ["", f"The same lines for navigate-{v['terrain']} trained with `{v['flags']}` ({v['changes']}; "
                  f"runs/{name}/, eval/{name}/), not the task's setting:", ""]  # fmt: skip
        lines += [_target_line(c) for c in v["targets"]]
    lines += ["", "## Training: one command per task", "",
              "| task | device | code | from process start to the result [s] | start-up [s] | training [s] | "
              "iterations | env-steps | stopped by | goals per episode (last episodes) | the result (validation: goals "
              "at 2 m, 8 bearings) |", "|---|---|---|---:|---:|---:|---:|---:|---|---:|---|"]  # fmt: skip
    for t, r in res["training"].items():
        chosen = next((c for c in r["candidates"] if c["chosen"]), None)
        pick = (f"{chosen['checkpoint']} ({chosen['why']}): {_pct(chosen['goal'])} of {r.get('validation_rounds')} "
                f"rounds, fell {_pct(chosen['fell_before_goal'])}") if chosen else "-"  # fmt: skip
        lines.append(f"| `python train.py --task {r['task']}{_label(t)[0]}` | {r.get('device_name')} | "
                     f"{r.get('revision') or '-'} | "
                     f"{r.get('wall_s_to_result', 0):.0f} | {r.get('startup_s', 0):.1f} | {r.get('train_s', 0):.0f} | "
                     f"{r.get('last_iteration', -1) + 1} of {r.get('max_iterations')} | {r.get('env_steps') or 0:,} | "
                     f"{r.get('stopped_by', '-')} | {_num(r.get('goals_per_episode'))} | {pick} |")  # fmt: skip
    lines += ["", "## Goals at 2 m and the 2 m square (Newton)", "",
              "| task | goals at \\|bearing\\| <= 90 deg | at 135-180 deg | time to a goal [s] | path / straight | "
              "falls | square completed | square time [s] | square falls | rounds | at most [s] (goal, square) | code | "
              "report |", "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---|"]  # fmt: skip
    for t, e in res["evaluation"].items():
        b, s = e["bearings"], e["square"]
        lines.append(f"| {_label(t)[1]} | {_pct(b['near']['reached'])} | {_pct(b['behind']['reached'])} | "
                     f"{b['all']['time_s']:.1f} | {b['all']['path_ratio']:.2f} | {_pct(b['all']['fall_rate'])} | "
                     f"{_pct(s['completed'])} | {s['time_s']:.1f} | {_pct(s['fall_rate'])} | {e['rounds']} each | "
                     f"{e['max_steps'][0] * dt:g}, {e['max_steps'][1] * dt:g} | {e.get('revision') or '-'} | "
                     f"[eval/{t}/report.md](eval/{t}/report.md) |")  # fmt: skip
    if res["evaluation"]:
        lines += ["", "Per bearing, and the command: each eval/T/report.md. The paths' top view: "
                  + ", ".join(f"[eval/{t}/{_figure(t)}](eval/{t}/{_figure(t)})" for t in res["evaluation"]) + "."]
    if res["sim2sim"]:
        lines += ["", "## The bundle in C MuJoCo through the same square", "",
                  "| task | rounds (MuJoCo / Newton) | completed | time [s] | falls | points apart | within "
                  f"{SIM2SIM_POINTS:g} |", "|---|---|---|---|---|---:|---|"]  # fmt: skip
        for t, s in res["sim2sim"].items():
            mj, nw = s["mujoco"], s["newton"]
            lines.append(f"| navigate-{t} | {mj['rounds']} / {nw['rounds']} | {_pct(mj['completed'])} / "
                         f"{_pct(nw['completed'])} | {mj['time_s']:.1f} / {nw['time_s']:.1f} | {_pct(mj['fall_rate'])} / "
                         f"{_pct(nw['fall_rate'])} | {s['points_apart']:.1f} | {'yes' if s['within'] else 'no'} |")  # fmt: skip
        lines += ["", "Commands: sim2sim/T/report.md."]
    if res["videos"]:
        lines += ["", "## Video", ""]
        for t, v in res["videos"].items():
            said = v["printed"][0].split("] ", 1)[-1] if v["printed"] else "-"
            lines.append(f"- media/square_{t}.mp4 (not tracked: `python studies/navigate/build.py video {t}` makes "
                         f"it): {said}. `{v['command']}` ({v['machine']}, {v['wall_s']:.0f} s; re-encoded: "
                         f"{v['encoded']})")  # fmt: skip
    lines += ["", "## The terrain patch's mesh", "",
              "[mesh/report.md](mesh/report.md): what the patch that holds every goal costs at start-up "
              "(`python3 studies/navigate/mesh_cost.py`).", ""]  # fmt: skip
    return "\n".join(lines)


def raw_missing() -> str:
    """'' when every kept run (``runs/TASK/``) has its console log; else the first that has none."""
    for t in (*TASKS, *VARIANTS):
        run = os.path.join(HERE, "runs", t)
        if os.path.isdir(run) and not os.path.exists(os.path.join(run, "train.log")):
            return f"runs/{t}/train.log"
    return ""


def build() -> dict:
    missing = raw_missing()
    if missing:
        raise RuntimeError(f"the raw runs are not in the tree ({missing}, not tracked): restore them with `git "
                           "restore --source df27913 --worktree -- studies/navigate/runs` or rerun queue.sh (README)")
    res = load()
    with open(os.path.join(HERE, "results.json"), "w") as f:
        json.dump(res, f, indent=1)
    with open(os.path.join(HERE, "report.md"), "w") as f:
        f.write(render(res))
    return res


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("what", nargs="*", help="video TASK: the square's video of a kept policy; else the report")
    ap.add_argument("--add", metavar="DIR", help="a lease's navigate queue outputs ($NAV of queue.sh, unpacked)")
    ap.add_argument("--revision", help="the commit the lease ran (its tree has no git)")
    args = ap.parse_args()
    try:
        if args.what:
            if len(args.what) != 2 or args.what[0] != "video" or args.what[1] not in TASKS:
                raise ValueError(f"expected 'video TASK' with TASK one of {', '.join(TASKS)}, got {' '.join(args.what)}")
            print(json.dumps(video(args.what[1])))
        if args.add:
            print("added: " + ", ".join(add(args.add, args.revision)))
        res = build()
    except (ValueError, RuntimeError) as exc:
        sys.exit(f"build.py: {exc}")
    met = sum(c["met"] for c in res["targets"])
    print(f"report.md, results.json: {met} of {len(res['targets'])} targets met"
          + (f"; partial: {'; '.join(res['partial'])}" if res["partial"] else ""))


if __name__ == "__main__":
    main()
