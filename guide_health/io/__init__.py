"""Everything guide_health reads or writes outside the process, by what it serves:

* ``bag/``: rosbag2 bags and the message formats on the wire: message types and topic names
  (`interfaces`), the CDR codec (`cdr`, also the live nodes' decoder), the rosbags typestore (`typestore`),
  the storage back ends in one table keyed by the storage identifier (`storage`, one module per back end
  behind `protocol.BagStorage`), reading (`reader`), writing (`writer`), summaries (`info`), run metadata
  (`metadata`) and maintenance events (`maintenance`);
* ``diagnostics_cdr``: fleet_monitor's reader of DiagnosticArray statuses from their raw CDR bytes;
* ``state_store``: the monitors' crash-safe state (SQLite, locking, validation);
* ``outputs/``: what the commands and nodes write for people and other programs: report files (`files`:
  no symbolic links, 0640), strict JSON (`json_text`), the progress bar (`progress`) and the fleet history
  (`fleet_history`).

Works offline: nothing here imports rclpy. Import the submodules themselves (no re-exports in the package
``__init__``), so that a live node importing `guide_health.io.bag.cdr` loads neither the reader nor the
writer.
"""
