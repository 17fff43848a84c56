"""What the simulator's world was built from for one flight, beside its truth log: ``<stem>.sim.json``.

The truth log (:mod:`sitl.truth_log`) holds poses, not the world they belong to.  To rebuild that world after the
flight (``gcs replay``, :mod:`sitl.replay_video`), the simulator writes a small JSON file with the truth log's stem
when it opens the log (at each arming): the vehicle file's name, path and text (so a file edited or moved since
replays as it was flown), the camera mount the model was built with (``SIM_CAM_MOUNT`` applied), whether the world
had the ground vehicle, the landing pad on its deck (each marker: id, side m, centre x and y m in the UGV's body
frame, x forward, y left), the scenario file, the seed, home (deg, deg, m AMSL) and every ``SIM_*`` parameter's
value at arming.

Flights logged before this file existed have none: :func:`read_setup` then gives None and :func:`guess_setup`
makes the likeliest setup from what the logs do hold (the number of motors, the UGV's columns, the gimbal's angles
and the markers the detector used), saying what it guessed.
"""

from __future__ import annotations

import json
import sys
import tempfile
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

from params.vehicle import VEHICLE_DIR, VehicleSpec, load_vehicle, vehicle_path
from sitl.scenario import scenario_path
from vision.pad import NESTED_PAD, SINGLE_PAD, PadLayout, PadMarker

SUFFIX = ".sim.json"
TRUTH_SUFFIX = ".truth.npy"
FORMAT_VERSION = 1


@dataclass(frozen=True)
class FlightSetup:
    """The world of one flight (the module docstring): enough to build its MuJoCo model again."""

    vehicle_name: str
    vehicle_file: str  # absolute path when flown ("" when unknown)
    vehicle_toml: str  # the vehicle file's text when flown ("" when unknown: read vehicle_file or the name)
    camera_mount: str  # "fixed" or "gimbal": the model as built
    ugv: bool
    pad: tuple[tuple[int, float, float, float], ...] = ()  # (id, side m, x m, y m) per marker; () without the UGV
    scenario: str | None = None
    seed: int = 0
    home: tuple[float, float, float] = (0.0, 0.0, 0.0)
    sim_params: dict[str, float] = field(default_factory=dict)
    version: int = FORMAT_VERSION

    def vehicle_spec(self) -> VehicleSpec:
        """The vehicle as flown: its file's recorded text (else the file, else the shipped name), on its mount."""
        if self.vehicle_toml:
            with tempfile.TemporaryDirectory(prefix="flight-setup-") as tmp:
                path = Path(tmp) / f"{Path(self.vehicle_file).stem or self.vehicle_name}.toml"
                path.write_text(self.vehicle_toml)
                spec = load_vehicle(str(path))
        else:
            spec = load_vehicle(self.vehicle_file if Path(self.vehicle_file).is_file() else self.vehicle_name)
        return spec.with_camera_mount(self.camera_mount)

    def pad_layout(self) -> PadLayout:
        """The pad on the UGV's deck (the nested pad when none was recorded)."""
        return PadLayout(tuple(PadMarker(int(i), s, x, y) for i, s, x, y in self.pad)) if self.pad else NESTED_PAD

    def to_json(self) -> str:
        return json.dumps(asdict(self), indent=1)

    @classmethod
    def from_json(cls, text: str) -> FlightSetup:
        """Raises ValueError for a file that is not such a setup (or a newer format)."""
        d = json.loads(text)
        if not isinstance(d, dict) or int(d.get("version", 0)) > FORMAT_VERSION:
            raise ValueError("not a flight setup this version can read")
        try:
            return cls(
                vehicle_name=str(d["vehicle_name"]),
                vehicle_file=str(d.get("vehicle_file", "")),
                vehicle_toml=str(d.get("vehicle_toml", "")),
                camera_mount=str(d["camera_mount"]),
                ugv=bool(d["ugv"]),
                pad=tuple((int(m[0]), float(m[1]), float(m[2]), float(m[3])) for m in d.get("pad", ())),
                scenario=d.get("scenario"),
                seed=int(d.get("seed", 0)),
                home=tuple(float(x) for x in d.get("home", (0.0, 0.0, 0.0))),  # type: ignore[arg-type]
                sim_params={str(k): float(v) for k, v in d.get("sim_params", {}).items()},
            )
        except (KeyError, TypeError, IndexError) as exc:
            raise ValueError(f"not a flight setup: {exc!r}") from None


def setup_path(truth: Path) -> Path:
    """The setup file that belongs to the truth log ``truth`` (same stem)."""
    name = truth.name[: -len(TRUTH_SUFFIX)] if truth.name.endswith(TRUTH_SUFFIX) else truth.stem
    return truth.with_name(name + SUFFIX)


def read_setup(truth: Path) -> FlightSetup | None:
    """The setup beside the truth log ``truth``; None when there is none (a flight logged before it existed).

    Raises ValueError for a file that cannot be read as one."""
    path = setup_path(truth)
    if not path.exists():
        return None
    try:
        return FlightSetup.from_json(path.read_text())
    except (OSError, ValueError) as exc:
        raise ValueError(f"{path}: {exc}") from None


def guess_setup(n_motors: int, ugv: bool, gimbal: bool, marker_ids: set[int]) -> tuple[FlightSetup, str]:
    """The likeliest setup of a flight logged without its setup file, and a sentence saying what was guessed.

    The vehicle: the first shipped vehicle file (by name) with ``n_motors`` rotors; the mount: the gimbal when the
    frame log has the gimbal's angles (``gimbal``); the pad: the single seed marker when the detector used that
    one alone (``marker_ids``), else the nested pad.
    """
    names = sorted(p.stem for p in VEHICLE_DIR.glob("*.toml"))
    vehicle = next((n for n in names if len(load_vehicle(n).rotors) == n_motors), None)
    if vehicle is None:
        raise ValueError(f"no shipped vehicle has {n_motors} motors; name the vehicle file (--vehicle)")
    single = bool(marker_ids) and marker_ids <= {SINGLE_PAD.pad_id}
    pad = SINGLE_PAD if single else NESTED_PAD
    setup = FlightSetup(
        vehicle_name=vehicle,
        vehicle_file="",
        vehicle_toml="",
        camera_mount="gimbal" if gimbal else "fixed",
        ugv=ugv,
        pad=tuple((m.marker_id, m.size_m, m.x_m, m.y_m) for m in pad.markers) if ugv else (),
    )
    pad_note = f", {'single' if single else 'nested'} pad" if ugv else ""
    note = f"no {SUFFIX} beside the truth log: guessed {vehicle} ({n_motors} motors), {setup.camera_mount} camera"
    return setup, note + pad_note


def _text(path: Path) -> str:
    """The file's text; "" when it cannot be read (the replay then loads the file by its path or name)."""
    try:
        return path.read_text()
    except OSError:
        return ""


class SetupRecorder:
    """Writes the flight's setup beside each truth log the simulator opens (``TruthRecorder.on_open``).

    ``args``: ``sitl``'s parsed command line (vehicle, scenario, seed, home); ``sim``: the vehicle's view of the
    world (:class:`sitl.simulation.VehicleView`); ``params``: its ``SIM_*`` parameters (read at each arming).
    The vehicle file is read once, here, at start-up: the one the model was built from.  A write that fails is
    reported once on stderr; the truth log goes on.
    """

    def __init__(self, args, sim, params) -> None:
        path = vehicle_path(args.vehicle).resolve()
        pad = sim.pad if sim.ugv is not None else None  # the deck it lands on (its own ids in a world of several)
        scenario = str(scenario_path(args.scenario).resolve()) if getattr(args, "scenario", None) else None
        self.params = params
        self.base = FlightSetup(
            vehicle_name=sim.spec.name,
            vehicle_file=str(path),
            vehicle_toml=_text(path),
            camera_mount=sim.spec.camera.mount,
            ugv=sim.ugv is not None,
            pad=tuple((m.marker_id, m.size_m, m.x_m, m.y_m) for m in pad.markers) if pad is not None else (),
            scenario=scenario,
            seed=int(args.seed),
            home=tuple(float(x) for x in args.home),  # type: ignore[arg-type]
        )
        self.failed = False

    def __call__(self, truth: Path) -> None:
        """Write ``<stem>.sim.json`` beside the truth log ``truth`` just opened."""
        if self.failed:
            return
        try:
            values = {p.name: float(self.params.get(p.name)) for p in self.params}
            setup_path(Path(truth)).write_text(replace(self.base, sim_params=values).to_json())
        except Exception as exc:
            self.failed = True
            print(f"[sitl] the flight's setup file was not written: {exc!r}", file=sys.stderr, flush=True)
