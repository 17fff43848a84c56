"""argparse ``type`` of the ``--vehicle`` options, light to import (the console scripts check their options
before loading anything heavy: NumPy, with :mod:`params.vehicle`, only once a value is checked)."""

from __future__ import annotations

import argparse


def vehicle_argument(name_or_path: str) -> str:
    """The vehicle name or path as given, once its file loads and checks (:func:`params.vehicle.load_vehicle`).

    A bad name or a broken file is then argparse's one ``error:`` line (exit 2), before anything starts.
    """
    from params.vehicle import VehicleFileError, load_vehicle

    try:
        load_vehicle(name_or_path)
    except VehicleFileError as exc:
        raise argparse.ArgumentTypeError(" ".join(str(exc).split())) from None
    return name_or_path
