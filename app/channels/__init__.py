"""The channels wiithrow produces, and the four sinks that carry them.

`registry` defines every channel once (its topic, meaning, JSON Schema, ROS 2 forms, QoS, Zenoh
key, latched or not); `json_messages`, `ros2_messages` (with `cdr`, `ros2_definitions`) and
`wiithrow.app.network.messages` are its encodings; `rig_messages` turns a rig's events into its
messages; `wall_time` stamps them in Unix time. The sinks: `mcap_sink` (a recording),
`foxglove_sink` (Foxglove live), `ros2_sink` (ROS 2 over DDS), `zenoh_sink` (Zenoh), the last three
in a writer process each (`sink_process`, `records`, `frame_ring`, `writer_process`, and each
one's `*_writer`); `follower` hands a source's frames to an in-process sink.
"""
