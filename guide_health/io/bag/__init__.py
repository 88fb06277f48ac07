"""rosbag2 bags and the message formats on the wire (see guide_health/io/__init__.py); the storage back ends
are in one table, `storage.BACKENDS`, each one module implementing `protocol.BagStorage` in full."""
