"""Several vehicles in one simulated world: ``sitl --count N`` and N ``autopilot`` processes.

::

    with MultiStack(3, speed="max", count=3) as stack:   # instances 3, 4, 5
        for k in range(stack.count):
            client = VehicleClient(stack.api_url_of(k), idle=stack.check_alive)

Vehicle k is instance ``instance + k`` (PX4's multi-vehicle scheme, :mod:`mavsim_core.ports`): the
simulator listens on TCP 4560+instance+k for its flight controller, which has system id 1+instance+k,
sends its API link to UDP 14540+instance+k and its ground-station link to ``gcs_port`` (one port for
all, as PX4 SITL sends every instance's to 14550).  The simulator's own component of vehicle k
(truth, ``SIM_*`` parameters) sends to UDP 14740+instance+k.  Logs: ``sitl.log`` and
``autopilot-<instance>.log`` per flight controller in ``log_dir``.
"""

from __future__ import annotations

from mavsim_core import ports

from . import stack_args
from .stack import Stack, StackError


class MultiStack(Stack):
    """``count`` vehicles in one world from ``instance`` on; every other argument as :class:`.stack.Stack`."""

    def __init__(self, instance: int = 0, *args, count: int = 2, **kwargs) -> None:
        super().__init__(instance, *args, **kwargs)
        if count < 1 or instance + count - 1 > ports.MAX_INSTANCE:
            raise StackError(f"count {count} from instance {instance}: instances must stay within 0-99")
        self.count = int(count)

    @property
    def instances(self) -> list[int]:
        """Every vehicle's instance number, vehicle 0 first."""
        return [self.instance + k for k in range(self.count)]

    def sysid_of(self, k: int) -> int:
        """MAVLink system id of vehicle ``k``'s flight controller."""
        return ports.system_id(self.instance + k)

    def api_url_of(self, k: int) -> str:
        """Where vehicle ``k``'s flight controller sends its API link (a client listens there)."""
        return f"udpin:0.0.0.0:{ports.api_port(self.instance + k)}"

    def truth_port_of(self, k: int) -> int:
        """Where vehicle ``k``'s simulator component (truth, ``SIM_*`` parameters) sends."""
        return ports.sim_component_port(self.instance + k)

    @staticmethod
    def autopilot_name(instance: int) -> str:
        """The name of a flight controller among the children (its log is ``<name>.log``)."""
        return f"autopilot-{instance}"

    def sitl_command(self) -> list[str]:
        return stack_args.sitl_command(self) + ["--count", str(self.count)]

    def autopilot_command_of(self, k: int) -> list[str]:
        """Vehicle ``k``'s flight controller's command line."""
        cmd = [self.python, "-m", *self.autopilot_module, "--vehicle", self.vehicle]
        cmd += ["--instance", str(self.instance + k), "--gcs-port", str(self.gcs_port)]
        return cmd + stack_args.log_dir_args(self, "autopilot") + self.extra_autopilot_args

    def _sitl_ports(self) -> list[tuple[int, int]]:
        return [(ports.sim_tcp_port(i), i) for i in self.instances]

    def _spawn_flight_controllers(self) -> None:
        for k, instance in enumerate(self.instances):
            self._spawn(self.autopilot_name(instance), self.autopilot_command_of(k))

    def restart_autopilot(self, timeout_s: float = 5.0) -> int | None:
        raise StackError("restart_autopilot: one flight controller of several; not supported by MultiStack")
