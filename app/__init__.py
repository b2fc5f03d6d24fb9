"""The running system: the worlds it acts in, the calibration runs, joint-1 alignment, the throws,
the operator's session, the studies behind the paper's figures, and the command line.

Rooms, lowest first (each imports only from those below it and from `wiithrow.throwing`,
`wiithrow.vision`, `wiithrow.robot`; pyproject.toml's import-linter contract checks it):

* `errors`, `settings`, `tables`: what every room shares;
* `rig`: the live rig (remotes -> synchroniser -> tracker), its simulated and real remotes, and
  waiting while it reads;
* `worlds`: the simulated world and the real one, behind one interface;
* `calibration`, `alignment`, `throws`: what the operator does with a world;
* `session`: the operator's session over all of them;
* `studies`: the paper's figures, the compensation experiment, the calibration methods compared;
* `cli`: the `wiithrow` command and its benchmarks, the only room above the dashboard
  (`wiithrow.web`).
"""
