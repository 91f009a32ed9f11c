"""Rollouts of a controller on any terrain, with statistics, Newton's viewers, recordings and a gait plot.

    python play.py                                                       # the newest trained policy on its terrain
    python play.py --controller cpg --terrain flat --num_envs 64 --steps 500
    python play.py --viewer gl                                           # in a window (the default with a display)
    python play.py --headless --video walk.mp4 --steps 1000              # a 20 s video, no display needed
    python play.py --viewer viser --steps 3000                           # in a browser: http://127.0.0.1:8080
    python play.py --viewer usd --out walk.usd                           # a recording for usdview / Omniverse
    python play.py --controller cpg --terrain stepped --record rollout.npz --plot gait.png
    python play.py --checkpoint logs/.../model_299.pt                    # its controller and course from the file
    python play.py --checkpoint results/policies/cpg_rl_complex.pt --terrain stepped --env.terrain.step_rise 0.07
    python play.py --checkpoint NAV.pt --waypoints 2,0 2,2 0,2 0,0 --viewer viser   # a waypoint course, drawn
    python play.py --robot mx_phoenix --controller cpg --num_envs 4 --steps 500    # another robot, the fixed CPG
    python play.py --robot path/to/robot.urdf --controller cpg                   # a robot file (docs/robots.md)

Without ``--controller`` and ``--checkpoint`` it plays the newest checkpoint under ``--log_dir`` (any task), or the
shipped ``results/policies/cpg_rl_complex.pt`` when nothing was trained; without ``--terrain``, on the course the
policy was trained on (its terrain without the curriculum's lanes, its goal distance; a navigate policy its random
goals). ``--waypoints X,Y ...`` gives every robot that waypoint course in its start frame (x along its start heading)
instead: the goals in turn, the last one's reaching ending the episode (no off-course end). ``--env.<section>.<field>``
sets any field of that course's config (HexConfig). ``--robot NAME|FILE`` walks another robot (the fixed CPG on it;
without ``--checkpoint``, the newest policy trained on it); a policy plays its own robot, and one line says so for
another (``train.py --init`` starts a policy for it from this one).

Controllers:
- ``cpg``: the paper's fixed-parameter "CPG" baseline (§3.3). The two-Hopf CPG and the mapping run with the
  constant parameters of ``CPGConfig`` (``fixed_*``); ``cpg_swept`` with the swept gait (``config.FIXED_GAITS``).
- ``cpg_rl``: a trained CPG_RL policy, acting deterministically (its distribution's mean).
- ``joint``: a trained pure-DRL policy that sets the 18 joint targets directly.
- ``sac_cpg``, ``td3_cpg``, ``a2c_cpg``: the skrl baselines (``python -m hexnewton.apps.baselines``), deterministic.

All of them run in the same ``HexapodEnv``, so episodes end and restart as §2.4.4 says (fall, off course,
success, timeout). The statistics cover each robot's first episode. ``--record PATH.npz`` stores, per
control step, the arrays listed under ``Recorder``.

Viewers (``hexnewton.physics.viewer``, Newton's ``--viewer`` convention): ``gl`` an OpenGL window (the default when there is a
display; ``--headless`` renders off-screen, through Mesa's software OpenGL on a machine without a GPU); ``--video
PATH.mp4`` writes what ViewerGL renders, captioned with the task and the time; ``viser`` serves the rollout as a web
page at ``--host``:``--port`` (127.0.0.1:8080: this machine only) in real time (x ``--video_speed``) until ``--steps``
end, ``--out PATH.viser`` also records it for playback in the browser; ``usd``, ``rerun`` and ``file`` write
``--out PATH`` (``.usd``, ``.rrd``, ``.json``/``.bin``) for offline inspection and replay; ``null`` draws nothing (the
default without a display, which play.py says in one line). They show the first terrain's rollout, the first ``--robots_shown`` robots.
"""

from __future__ import annotations

import os
import sys
import time
from dataclasses import replace

from hexnewton.analysis.rollout import BASELINES, CONTROLLERS, FIXED
from hexnewton.apps.cli import (
    ArgumentParser,
    add_browser_args,
    add_config_args,
    add_robot_args,
    announce_browser,
    check_checkpoint_file,
    check_writable,
    config_overrides,
    positive_int,
    robot_from_args,
    run,
    terrain_name,
    waypoint,
)
from hexnewton.config import TERRAINS, HexConfig
from hexnewton.physics.viewer import VIEWERS


def parser() -> ArgumentParser:
    """The command line of ``python play.py``."""
    p = ArgumentParser(prog="python play.py", description="Rollouts with statistics and Newton's viewers.")
    p.add_argument("--controller", choices=list(CONTROLLERS), default=None,
                   help="default: the checkpoint's (cpg_rl, joint or a baseline's); cpg is the fixed gait and takes no "
                        "checkpoint")
    p.add_argument("--checkpoint", metavar="PATH", help="a trained policy (.pt); default: the newest under --log_dir, "
                   "else results/policies/cpg_rl_complex.pt")  # fmt: skip
    p.add_argument("--log_dir", default="logs")
    add_robot_args(p, "the policy's own (the fixed CPG: the paper's)")
    p.add_argument("--terrain", type=terrain_name, nargs="+", default=None,
                   help=f"one or more of {TERRAINS} as §3.1 defines them (default: the policy's training course, else "
                        "flat)")
    p.add_argument("--waypoints", nargs="+", type=waypoint, metavar="X,Y",
                   help="a waypoint course in each robot's start frame [m] (x along its start heading), e.g. 2,0 2,2 "
                        "0,2 0,0: the goals in turn; the viewers draw them")  # fmt: skip
    p.add_argument("--num_envs", type=positive_int, default=64)
    p.add_argument("--steps", type=positive_int, default=500, help="control steps (20 ms each by default)")
    p.add_argument("--device", default=None, help="cpu, cuda or cuda:N (default: cuda if present, else cpu)")
    p.add_argument("--seed", type=int, default=0, help="terrain and reset seed")
    p.add_argument("--record", metavar="PATH.npz", help="save the rollout (first terrain)")
    p.add_argument("--viewer", choices=VIEWERS, default=None,
                   help="Newton viewer (default: gl with a display or --video, else null)")
    p.add_argument("--headless", action="store_true", help="gl: render off-screen (implied by --video without a display)")
    p.add_argument("--video", metavar="PATH.mp4", help="write the rendered frames as an .mp4 (ViewerGL)")
    p.add_argument("--out", metavar="PATH", help="the recording of --viewer usd (.usd), rerun (.rrd), file (.json/.bin) "
                   "or viser (.viser, beside the live page)")  # fmt: skip
    add_browser_args(p)
    p.add_argument("--robots_shown", type=positive_int, default=3, help="robots shown by the viewer (the first lanes)")
    p.add_argument("--video_speed", type=positive_int, default=1,
                   help="playback speed (x real time): one frame every video_speed control steps")  # fmt: skip
    actions = p.add_mutually_exclusive_group()
    actions.add_argument("--stochastic", action="store_true",
                         help="cpg_rl / joint: sample actions from the policy's Gaussian as in training "
                              "(default: the mean)")
    actions.add_argument("--expected", action="store_true",
                         help="cpg_rl / joint: the expected clipped action E[clip(a, -1, 1)] of the Gaussian "
                              "(deterministic)")
    p.add_argument("--plot", metavar="PATH.png", help="plot the six legs' joint targets over two gait cycles")
    p.add_argument("--no-progress", action="store_true")
    add_config_args(p, "env", HexConfig(task=replace(HexConfig().task, reset_yaw=0.0)),
                    skip=("sim.num_envs", "sim.device", "task.seed", "terrain.seed", "terrain.name"),
                    title="--env.*: a field of the course (HexConfig); sim.* and cpg.* default to the policy's own, "
                          "task.reset_yaw to 0 (every robot starts facing its goal; training uses 0.2)")  # fmt: skip
    return p


def check_outputs(args) -> None:
    """Fail before any simulation if an output could not be written; choose the viewer (``--viewer`` or the default
    for a display, ``--video`` and ``--out``) and whether it renders off-screen."""
    for path, ext in ((args.record, ".npz"), (args.plot, ".png")):
        if path:
            check_writable(path, ext)
    from hexnewton.physics.viewer import check_viewer_args, default_viewer, has_display

    if args.viewer is None and default_viewer(args.video, args.out) == "null":
        print("no display: nothing is drawn; --viewer viser serves the robots to a browser, --video PATH.mp4 renders "
              "them off-screen (--viewer null for statistics alone)")
    args.viewer = args.viewer or default_viewer(args.video, args.out)
    args.headless = args.headless or (args.video is not None and not has_display())
    check_viewer_args(args.viewer, args.headless, args.video, args.out, args.host, args.port)
    for path in (args.video, args.out):
        if path:
            check_writable(path, os.path.splitext(path)[1])


def choose_checkpoint(args) -> None:
    """``args.checkpoint`` for a learnt controller given none: the newest under ``--log_dir``, else the shipped
    policy; ValueError for a fixed gait given one."""
    if args.controller in FIXED and args.checkpoint:
        raise ValueError(f"--checkpoint is a trained policy's: the fixed CPG (--controller {args.controller}) has "
                         "none; use --controller cpg_rl or joint, or leave --controller out")  # fmt: skip
    if args.controller not in FIXED and args.checkpoint is None:
        from hexnewton.learning.checkpoint import SHIPPED_POLICY, newest_checkpoint

        robot = args.robot_cfg.name if args.robot_cfg is not None else "paper"
        try:  # the newest policy of the robot: train.py names another robot's runs hexnewton_<task>_<robot>
            args.checkpoint = newest_checkpoint(args.log_dir, "hexnewton_*" + (f"_{robot}" if robot != "paper" else ""))
        except ValueError:
            if robot != "paper":
                raise ValueError(f"no policy trained on robot {robot} under {args.log_dir}: --controller cpg walks it "
                                 f"with the fixed CPG, python train.py --robot {args.robot} trains one") from None
            if args.controller == "joint" or not os.path.isfile(SHIPPED_POLICY):
                raise
            args.checkpoint = SHIPPED_POLICY
        print(f"playing {args.checkpoint}")


def read_policy(args):
    """(the config the policy was trained with, the courses to play, its checkpoint, its task) for ``args.checkpoint``
    (read once, before any world is built; ``args.controller`` defaults to the one that runs it), or the defaults for
    a fixed gait."""
    from hexnewton.robot.registry import check_robot, with_robot

    if not args.checkpoint:
        robot = args.robot_cfg
        return (with_robot(HexConfig(), robot) if robot else HexConfig()), args.terrain or ["flat"], None, None
    from hexnewton.learning.checkpoint import checkpoint_task, is_baseline_checkpoint, trained_config
    from hexnewton.learning.policy import policy_checkpoint

    ckpt, default = policy_checkpoint(args.checkpoint)  # fails before building a world
    trained, task = trained_config(ckpt), checkpoint_task(ckpt)
    check_robot(trained.robot, args.robot_cfg, args.checkpoint, init=not is_baseline_checkpoint(ckpt))
    if args.controller is None:
        args.controller = default
    if (args.controller in BASELINES) != (default in BASELINES):
        raise ValueError(f"{args.checkpoint} is run by controller {default}, not {args.controller}")
    return trained, args.terrain or [trained.terrain], ckpt, task  # the policy's own course


def play_course(args, ground, first: bool, trained: HexConfig, ckpt: dict | None, task: str | None) -> None:
    """One course's rollout of the controller with its statistics; on the ``first`` course also the recording and
    the viewer."""
    from hexnewton.analysis.metrics import format_stats
    from hexnewton.analysis.rollout import Recorder, controller_policy, rollout
    from hexnewton.mdp.env import make_env
    from hexnewton.tasks import course

    from hexnewton.analysis.navigation import played_goals

    cfg = course(ground, trained, config_overrides(args, "env"), args.num_envs, args.device, args.seed,
                 seed=args.seed, reset_yaw=0.0, **played_goals(trained.task, args.waypoints))  # fmt: skip
    terrain = cfg.terrain.name
    env = make_env(cfg, CONTROLLERS[args.controller])
    policy = controller_policy(env, args.controller, args.checkpoint, ckpt, args.stochastic, args.expected)
    if args.stochastic and args.controller not in FIXED and args.controller not in BASELINES:
        import torch

        torch.manual_seed(args.seed)
    recorder = Recorder() if (args.record and first) else None
    viewer = None
    if args.viewer != "null" and first:
        from hexnewton.physics.viewer import RolloutViewer

        viewer = RolloutViewer(args.viewer, headless=args.headless, video=args.video, out=args.out,
                               robots=args.robots_shown, stride=args.video_speed,
                               title=(f"task {task}: " if task else "") + f"{args.controller} on {terrain}",
                               control_dt=cfg.task.control_dt, host=args.host, port=args.port,
                               realtime=args.viewer == "viser")  # fmt: skip
        if viewer.url:
            announce_browser(viewer.url, args.host, f"serving until the {args.steps} control steps end")
    t0 = time.perf_counter()
    try:
        stats = rollout(env, policy, args.steps, tuple(r for r in (recorder, viewer) if r is not None),
                        progress=not args.no_progress and sys.stderr.isatty())  # fmt: skip
    finally:
        if viewer is not None:
            viewer.close()
    wall = time.perf_counter() - t0
    label = args.controller if args.controller in FIXED else f"{args.controller} ({args.checkpoint})"
    print(f"[{label}] " + format_stats(terrain, stats, stats["control_s"])
          + f"  [{wall:.1f} s wall, {env.device}]")  # fmt: skip
    if recorder is not None:
        recorder.save(args.record)
        print(f"recorded {args.steps} steps x {args.num_envs} envs to {args.record}")
    if viewer is not None:
        where = {"gl": f"in ViewerGL{' (headless)' if args.headless else ''}", "viser": "served to the browser"}
        wrote = [f"{viewer.frames} frames {where.get(args.viewer, f'to {args.out}')}"]
        if args.viewer == "viser" and args.out:
            wrote.append(f"recording written to {args.out}")
        if args.video:
            wrote.append(f"video written to {args.video}")
        print(f"viewer {args.viewer}: " + ", ".join(wrote))


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    if args.checkpoint:
        check_checkpoint_file(args.checkpoint)  # a run's folder: one line naming its result, before anything else
    check_outputs(args)
    args.robot_cfg = robot_from_args(args)
    choose_checkpoint(args)
    trained, courses, ckpt, task = read_policy(args)
    for i, ground in enumerate(courses):
        play_course(args, ground, i == 0, trained, ckpt, task)
    if args.plot:
        from hexnewton.analysis.plotting import plot_gait

        from hexnewton.robot.registry import with_robot

        plot_gait(with_robot(HexConfig(), trained.robot), args.plot)  # the fixed CPG on the played robot
        print(f"gait plot written to {args.plot}")
    return 0


if __name__ == "__main__":
    sys.exit(run(main, "python play.py"))
