"""Bags and state on disk: message types and topic names (`interfaces`), CDR codec (`cdr`, also the
live nodes' decoder), rosbags typestore (`typestore`), bag storage back ends behind one protocol
(`storage`), bag reading (`bag_reader`), writing (`bag_writer`) and summaries (`bag_info`), run
metadata (`bag_metadata`), the progress bar (`progress`) and the monitors' crash-safe state
(`state_store`).

Works offline: nothing here imports rclpy. Import the submodules themselves (no re-exports here), so
that a live node importing `guide_health.io.cdr` loads neither the reader nor the writer.
"""
