"""The landing pad: one or more ArUco markers of ``DICT_ARUCO_ORIGINAL`` printed on the deck (issue 34, item 4).

Pad frame: origin at the pad's centre (the landing point, the point LANDING_TARGET reports), x to the right of
the printed image, y up the printed image, z out of the pad towards the viewer; metres.  Every marker is printed
upright (its own frame, :mod:`vision.marker`, is the pad frame moved to its centre); on the UGV's deck the pad
frame is the UGV's body frame (x forward, y left, z up).

Layouts:
- :data:`SINGLE_PAD`: the seed's pad, marker 76, 0.333 m, at the centre ([F 2.3]).
- :data:`NESTED_PAD` (the default): a board.  Four markers of the seed's size (76, 151, 113, 813; 0.333 m, so
  each is found as far away as the seed's marker) at (+-0.33, +-0.33) m, around a small one (42, 0.125 m) at the
  centre, so the camera still sees a whole marker in the last half metre, when the large ones no longer fit in
  the frame.  The large markers are centred on the pad's centre: from afar the pose is one solve over their 16
  corners spread over a metre, better conditioned than one marker's 4 (depth from the markers' spread, not from
  one 23 px square), and a tilt error does not move the centre as it would move a marker's offset
  (:mod:`vision.pad_pose`).  Each marker keeps its white quiet border of one cell (OpenCV's detector finds a
  marker only with white around its black border) and none is printed inside another one's cells (that would
  corrupt its bits).  The first marker (76) names the pad, the second is the centre one.

:func:`check_pad` refuses a layout that cannot be printed and seen: no marker, a duplicate id, an id outside the
dictionary, a side not > 0, two markers (with their quiet borders) that overlap, or one that does not fit on the
deck.  The error names the key (``pad.markers[1].size_m``) so a scenario file's reader can report it in one line.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vision.marker import MARKER_BITS, MARKER_ID, MARKER_SIZE_M, marker_corners_3d

DICTIONARY_SIZE = 1024  # DICT_ARUCO_ORIGINAL's ids: 0 .. 1023
INNER_MARKER_ID = 42
INNER_MARKER_SIZE_M = 0.125  # 6 texels a cell on the deck's texture (the large marker has 16): drawn exactly
OUTER_MARKER_IDS = (MARKER_ID, 151, 113, 813)  # ids 10+ bits apart (under any rotation) from each other and 42
OUTER_MARKER_OFFSET_M = 0.33  # each outer marker's centre from the pad's centre along x and along y (111 texels)


@dataclass(frozen=True)
class PadMarker:
    """One marker of the pad: its id, the side of its black square (m) and its centre in the pad frame (m)."""

    marker_id: int
    size_m: float
    x_m: float = 0.0
    y_m: float = 0.0

    @property
    def quiet_border_m(self) -> float:
        """The white margin the marker needs around its black square: one cell (m)."""
        return self.size_m / (MARKER_BITS + 2)

    def corners_pad_m(self) -> np.ndarray:
        """(4, 3) corners of the black square in the pad frame (m), in OpenCV's detector order."""
        return marker_corners_3d(self.size_m) + np.array((self.x_m, self.y_m, 0.0))


@dataclass(frozen=True)
class PadLayout:
    """The markers of a pad, the first one its name (LANDING_TARGET's ``target_num``)."""

    markers: tuple[PadMarker, ...]

    @property
    def pad_id(self) -> int:
        return self.markers[0].marker_id

    def marker(self, marker_id: int) -> PadMarker | None:
        """The pad's marker with ``marker_id``, or None if the pad has none."""
        return next((m for m in self.markers if m.marker_id == marker_id), None)


SINGLE_PAD = PadLayout((PadMarker(MARKER_ID, MARKER_SIZE_M),))
_CORNERS = ((1, 1), (-1, -1), (1, -1), (-1, 1))  # front left, rear right, front right, rear left (x forward, y left)
NESTED_PAD = PadLayout(
    (
        PadMarker(MARKER_ID, MARKER_SIZE_M, OUTER_MARKER_OFFSET_M, OUTER_MARKER_OFFSET_M),
        PadMarker(INNER_MARKER_ID, INNER_MARKER_SIZE_M),
        *(
            PadMarker(i, MARKER_SIZE_M, sx * OUTER_MARKER_OFFSET_M, sy * OUTER_MARKER_OFFSET_M)
            for i, (sx, sy) in zip(OUTER_MARKER_IDS[1:], _CORNERS[1:])
        ),
    )
)


class PadLayoutError(ValueError):
    """A pad that cannot be printed or seen; ``key`` names the offending setting, ``reason`` says why."""

    def __init__(self, key: str, reason: str) -> None:
        self.key, self.reason = key, reason
        super().__init__(f"{key}: {reason}")


def check_pad(pad: PadLayout, deck_side_m: float, key: str = "pad.markers") -> PadLayout:
    """``pad`` if it can be printed on a square deck of ``deck_side_m`` and seen; else raise :class:`PadLayoutError`."""
    if not pad.markers:
        raise PadLayoutError(key, "the pad needs at least one marker")
    half_deck = 0.5 * deck_side_m
    for i, m in enumerate(pad.markers):
        where = f"{key}[{i}]"
        if not 0 <= m.marker_id < DICTIONARY_SIZE:
            raise PadLayoutError(f"{where}.id", f"{m.marker_id} is not an id of DICT_ARUCO_ORIGINAL (0-1023)")
        if any(p.marker_id == m.marker_id for p in pad.markers[:i]):
            raise PadLayoutError(f"{where}.id", f"id {m.marker_id} is on the pad twice")
        if not m.size_m > 0.0:
            raise PadLayoutError(f"{where}.size_m", f"must be > 0, not {m.size_m}")
        reach = 0.5 * m.size_m + m.quiet_border_m
        if max(abs(m.x_m), abs(m.y_m)) + reach > half_deck + 1e-9:
            raise PadLayoutError(
                where, f"does not fit on the {deck_side_m:g} m deck with its white border of {m.quiet_border_m:.3g} m"
            )
        for j, other in enumerate(pad.markers[:i]):
            gap = reach + 0.5 * other.size_m + other.quiet_border_m
            if abs(m.x_m - other.x_m) < gap - 1e-9 and abs(m.y_m - other.y_m) < gap - 1e-9:
                raise PadLayoutError(where, f"overlaps {key}[{j}] (id {other.marker_id}) or its white border")
    return pad


def vehicle_pad(pad: PadLayout, k: int) -> PadLayout:
    """The pad on the deck of vehicle ``k``'s own ground vehicle in a world of several: ``pad``'s markers (sizes,
    places) with ids of its own, so that no two decks share an id and each companion looks for its own deck's
    markers only.  Vehicle 0's is ``pad`` itself; vehicle k's takes, for each marker in order, the first id from
    its id + k on (modulo the dictionary) that no pad 0..k-1 uses and no earlier marker of its own took."""
    if k == 0:
        return pad
    used = {m.marker_id for j in range(k) for m in vehicle_pad(pad, j).markers}
    markers = []
    for m in pad.markers:
        new = (m.marker_id + k) % DICTIONARY_SIZE
        while new in used:
            if len(used) >= DICTIONARY_SIZE:
                raise PadLayoutError("pad.markers", f"no free marker ids left for vehicle {k}'s pad")
            new = (new + 1) % DICTIONARY_SIZE
        used.add(new)
        markers.append(PadMarker(new, m.size_m, m.x_m, m.y_m))
    return PadLayout(tuple(markers))
