"""The companion computer: finds the landing pad's ArUco marker in camera frames and reports it
as MAVLink LANDING_TARGET ([F 2.3], issue 13).  Imports nothing of autopilot, sitl or gcs."""
