"""Foxglove live: a rig's (or a session's, or a replay's) channels served to Foxglove over its
WebSocket protocol by foxglove-sdk's own server (`server`; `live` in this process, `process_live` and
`session_process_live` through a writer process, `writer_main`; `player` for a recording). docs/integrations/foxglove.md."""
