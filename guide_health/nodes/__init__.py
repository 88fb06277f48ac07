"""Thin rclpy adapters around guide_health.models."""
