"""Zenoh: the session, the payloads, and the markers received from another host.

`messages` (key expressions under `wiithrow/<rig-name>/` and the JSON payloads, schema 1: the
Zenoh sink's encoding, `wiithrow.app.channels.zenoh_sink`), `frame_auth` (every sample signed),
`zenoh_session` (opening a Zenoh session: peer mode by default, a config file for routers),
`subscriber` (receiving samples: `wiithrow listen`), `remote_rig` (`RemoteRig`: the marker source
of the markers another host publishes, `serve --markers-from`), and what its frames pass.
docs/integrations/zenoh.md documents the keys and payloads.
"""
