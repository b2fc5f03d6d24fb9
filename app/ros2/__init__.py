"""ROS 2 on the wire: the rig's markers, frames, dots and throws as ROS 2 topics over DDS (Cyclone
DDS), which a ROS 2 node receives with no bridge: `messages` (the types, as ROS 2 defines them;
`idl/` the same as IDL), `domain` (the loopback-only configuration, the domain, ROS 2's QoS and
names); the publisher is the ROS 2 sink, `wiithrow.app.channels.ros2_sink`. docs/integrations/ros2.md."""
