"""The Viser dashboard: a view of the running system and the operator's buttons.

It observes and commands an `wiithrow.app.session.session.Session` through its public methods, and reads the world
and the calibration the session exposes; it never does work the session should do. Modules, one
job each:

* `server`: `Dashboard`, the assembly: viser server, refresh thread, button handlers;
* `access`: who may connect (Host, Origin, the operator token) and what each role may send;
* `handshake`: those checks installed in viser's websocket server;
* `clients`: each connected browser's role and controls, the check every click passes;
* `controls`: a browser's own buttons (an operator's work, a guest's are disabled);
* `live`: what one refresh reads from the running system (`LiveState`);
* `scene`: the 3D scene in the robot's `base` frame;
* `arm_view`: the arm from its URDF, posed cheaply from joint angles;
* `camera_views`: each camera's image plane with its dots;
* `panels`: the shared panel (Stop, status, calibration, throw, table, plots);
* `operations`: operations in worker threads, one at a time, notifications;
* `analysis`: slow derived figures in a worker process;
* `throttle`: the refresh rate and the cost of each refresh.

`wiithrow demo` runs it on the simulated system (`wiithrow.app.cli.commands.demo`); `wiithrow bench dashboard`
measures its cost (`wiithrow.app.cli.bench.dashboard`).
"""
