"""Pieces every module sheet repeats: the fused bus tap and the board's silkscreen frame."""
from __future__ import annotations

from ..design import Place, Sheet, Text


def bus_tap(s: Sheet, net: str, at: Place) -> None:
    """+5V from the bus through a 0.5 A-hold polyfuse to the module's own supply `net`.

    A module that shorts internally then trips its own polyfuse instead of dragging the whole
    bus into the PSU's current limit. The bus itself passes through the module unfused."""
    s.part("F101", "PTC_500mA", {"1": "+5V", "2": net}, at=at)
    s.flags += ["GND", net]


def frame_texts(name: str, revision: str) -> list[Text]:
    """Module name and revision, the bus port labels over the jacks, the sensor-edge note."""
    return [
        Text(f"R2P {name.upper()}", 30.0, 49.0 - 1.6, 1.2),
        Text(f"rev {revision}", 51.0, 49.0 - 1.6, 0.8),
        Text("BUS IN", 12.0, 19.8, 1.0),
        Text("BUS OUT", 44.0, 19.8, 1.0),
    ]
