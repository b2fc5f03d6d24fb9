"""The MuJoCo world: the whole system in a physics the planner does not know, reached only through
the interfaces real hardware implements (docs/simulation.md, "The MuJoCo world").

Modules: `params` (the PA-10's dynamics with their sources, the hand, the ball), `model` (the
MuJoCo model from the URDF: dynamics, tolerances, hand, ball, floor, table, LED sites), `servo`
(the amplifier's PI velocity loops), `cycle` (the servo periods compiled: the host's law, the
servo and `mj_step` in a numba loop), `lab` (the physics on the world's clock, the ball's events,
the simulated operator), `devices` (the arm driver, the servo interface, the hand), `drivers`
(the devices as settings-named factories, for `wiithrow serve`), `world` (`MujocoWorld`).
Import `wiithrow.app.worlds.mujoco.world` for the world; this package imports nothing itself, so
that `import wiithrow.app.worlds` does not load MuJoCo.
"""
