"""The flight controller's MAVLink edge: everything that speaks MAVLink lives here.

* :mod:`~autopilot.mavlink.link`: :class:`~autopilot.mavlink.link.GcsLink`, the two UDP
  endpoints to ground stations and APIs (PX4 SITL ports), peers, heartbeats, stream
  scheduling, the traffic tap; it composes the modules below and is imported by none of
  them (an import contract in pyproject.toml: no cycle inside this package);
* :mod:`~autopilot.mavlink.endpoint`: one UDP endpoint with its send batching and streams;
* :mod:`~autopilot.mavlink.command_dispatch`: one command in, one COMMAND_ACK out;
* :mod:`~autopilot.mavlink.message_requests`: message intervals and messages sent once on request;
* :mod:`~autopilot.mavlink.telemetry`: telemetry messages as pure functions of the
  vehicle's state (:class:`autopilot.topics.TelemetrySnapshot`) and time;
* :mod:`~autopilot.mavlink.commands`: the one table from MAV_CMD to handler;
* :mod:`~autopilot.mavlink.param_service`: the parameter protocol;
* :mod:`~autopilot.mavlink.mission_protocol`: the mission protocol (mission, fence, rally plans);
* :mod:`~autopilot.mavlink.vehicle_interface`: what the link needs from the vehicle, and its
  implementation for a :class:`~autopilot.flight_controller.FlightController`;
* :mod:`~autopilot.mavlink.sim_link`: the simulator link (PX4's simulator MAVLink API, TCP).

Units: SI and radians inside the flight controller; degE7, mm, cm/s, centidegrees and mV
only here, where messages are encoded and decoded.
"""
