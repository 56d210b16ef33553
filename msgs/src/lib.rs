//! rodlog message vocabulary: ROS 2 message structs, CDR codec, ros2msg schemas, topic registry, the Stage and driver traits.
