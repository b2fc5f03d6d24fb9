"""Publishing the rig over Zenoh: tracked markers, each camera's dots and throws, for other hosts.

`messages` (key expressions under `wiithrow/<rig-name>/` and the JSON payloads, schema 1),
`zenoh_session` (opening a Zenoh session: peer mode by default, a config file for routers),
`publisher` (`RigPublisher`: puts frames; `RigFollower`: publishes what a marker source's events
bring), `process_publisher` (`ZenohProcessPublisher`: what `--publish` runs, a `RigPublisher` in
a writer process, `zenoh_writer`, fed through a ring of `zenoh_records`), `subscriber` (receiving samples: `wiithrow listen`), `remote_rig` (`RemoteRig`: the marker
source of the markers another host publishes, `serve --markers-from`).
docs/integrations/zenoh.md, documents the keys and payloads.
"""
