"""A whole-body Panda plan executed in MuJoCo: contacts, tracking error, final error, and a rendered frame.

Run: ``python examples/sim/execute_in_mujoco.py [--output-dir DIR] [--width W --height H]`` (needs the ``sim``
extra). What to look at: the printed report — 0 steps in contact with the table and the pitcher, the largest
tracking error (rad) while the trajectory plays, and the end effector's final error against the goal, which is
the plan's own (its goal tolerance is 1 cm) plus what the servos add (a fraction of a millimetre). The PNG
(``mujoco_run.png``) is MuJoCo's offscreen render half-way through the trajectory, driven through
:meth:`pfield.sim.Simulation.step` (the servo-loop entry point): the Panda's collision meshes in grey, the
obstacles in orange, the planned end-effector path in blue.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from pfield import RobotModel
from pfield.demo.whole_body import PANDA_GOAL, PANDA_OBSTACLES, plan_panda_demo
from pfield.sim import Simulation, render_frame
from pfield.sim.render import PIXELS
from pfield.sim.simulation import hermite_reference


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--output-dir", type=Path, default=Path("demo_output") / "examples")
    parser.add_argument("--width", type=int, default=960, help="picture width in pixels")
    parser.add_argument("--height", type=int, default=640, help="picture height in pixels")
    args = parser.parse_args()
    for name in ("width", "height"):  # render_frame's range, checked before the minute of planning and simulating
        if not PIXELS[0] <= getattr(args, name) <= PIXELS[1]:
            parser.error(f"--{name} {getattr(args, name)}: expected a whole number of pixels in {list(PIXELS)}")
    try:
        args.output_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        parser.error(f"--output-dir {args.output_dir}: {exc.strerror}")
    robot = RobotModel.builtin("panda")
    path, _start = plan_panda_demo(robot)
    print(f"plan: success={path.success}, {len(path)} waypoints, trajectory {path.duration:.2f} s retimed to "
          f"{path.trajectory.duration if path.trajectory else float('nan'):.2f} s")
    sim = Simulation(robot, PANDA_OBSTACLES)
    report = sim.execute(path, PANDA_GOAL)
    print(f"executed in MuJoCo: {report.steps} steps of {sim.timestep * 1e3:.0f} ms in {report.wall_time:.2f} s; "
          f"steps in contact with obstacles {report.obstacle_contacts}; self-contact steps "
          f"{report.contacts.self_steps}")
    print(f"max tracking error {report.max_tracking_error:.4f} rad ({report.max_tracking_joint}); final "
          f"end-effector error {report.final_position_error * 1e3:.2f} mm, {report.final_rotation_error:.4f} rad")
    assert path.trajectory is not None
    sim.reset(path.trajectory.positions[0])  # replay the first half through step(), the servo-loop entry point
    half = path.trajectory.duration / 2
    times = np.arange(1, int(half / 0.01) + 1) * 0.01
    for positions, velocities in zip(*hermite_reference(path.trajectory, times), strict=True):
        sim.step(positions, velocities, dt=0.01)
    target = render_frame(sim, args.output_dir / "mujoco_run.png", width=args.width, height=args.height,
                          lookat=(0.35, 0.0, 0.3), distance=1.7, azimuth=-140.0, elevation=-22.0,
                          trail=path.positions[::4])
    print(f"wrote {target} (t = {sim.state.time:.2f} s)")


if __name__ == "__main__":
    main()
