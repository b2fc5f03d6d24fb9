"""Foxglove live: a rig's (or a session's, or a replay's) channels served to Foxglove over its
WebSocket protocol by foxglove-sdk's own server (`live`). README, "ROS 2" (Foxglove)."""
