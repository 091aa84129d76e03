"""Helpers of the ROS 2 transport tests: availability checks, a network-namespace session runner,
a blocking rclpy client and test-only nodes. Scripts here run as separate processes."""
