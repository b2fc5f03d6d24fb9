"""Foxglove live: a rig's (or a session's, or a replay's) channels served to Foxglove over its
WebSocket protocol by foxglove-sdk's own server (the Foxglove sink, `wiithrow.app.channels.foxglove_sink`;
`live` in this process, `session_process_live` through a writer process; `player` for a
recording, on Foxglove's timeline). docs/integrations/foxglove.md."""
