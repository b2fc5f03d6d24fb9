"""The marker source and the local rig.

`source` (`MarkerSource`: what every consumer of tracked markers uses, whoever tracks them),
`events` (what a source tells its listeners), `pipeline` (`TrackingPipeline`: frames ->
synchroniser -> tracker, shared by the local rig and the replay), `stream` (`RigStream`: C
Wiimote drivers -> their report decoders -> the pipeline), the drivers over simulated remotes
(`simulated`) or the real ones hidapi finds (`hardware`), moving test markers (`moving_markers`),
and letting time pass on the clock while the source keeps reading (`waiting`)."""
