"""Pieces every module sheet repeats: the fused bus tap and the board's silkscreen frame."""
from __future__ import annotations

from ..design import Place, Sheet, Text, Track


def bus_tap(s: Sheet, net: str, at: Place) -> None:
    """+5V from the bus through a 0.5 A-hold polyfuse to the module's own supply `net`.

    A module that shorts internally then trips its own polyfuse instead of dragging the whole
    bus into the PSU's current limit. The bus itself passes through the module unfused."""
    s.part("F101", "PTC_500mA", {"1": "+5V", "2": net}, at=at)
    s.flags += ["GND", net, "+5V"]     # +5V arrives from the bus jacks (passive pins)


BUS_TAP_PLACE = Place(6.0, 20.5, 270)


def bus_tap_track() -> Track:
    """F101's bus side to BUS IN's +5V pin 7 on F.Cu."""
    return Track("+5V", [(6.0, 19.1), (8.0, 17.2), (8.0, 15.5), (10.6, 13.52), (12.58, 13.52)], 0.6)


def tvs_track() -> Track:
    """The +5V TVS D5's cathode (pad 1, below) to the bus tap track, on F.Cu: the shortest path
    from the jack's +5V to the clamp (the autorouter has no room left of J1)."""
    return Track("+5V", [(4.2, 14.6), (7.1, 14.6), (8.0, 15.5)], 0.6)


def core_tracks() -> list[Track]:
    """Hand-routed core signals for the default core placement (the autorouter boxes this one in)."""
    return [Track("LED_STATUS", [(7.325, 24.0), (8.6, 24.0), (10.1, 25.5), (24.0, 25.5),
                                 (24.75, 26.25), (25.84, 26.25)], 0.2)]


def frame_texts(name: str, revision: str, bus_in: tuple[float, float] = (21.0, 18.4)) -> list[Text]:
    """The silkscreen every module shares: bus port names, bus header pinout, termination switch
    on the top; the module's name and revision large on the back, where nothing covers them.

    BUS IN sits under J1 where the parts below the jack leave a gap (`bus_in`: the core's
    placement leaves one right of C7; a module that moves core parts passes its own), clear of
    pads and outlines as silk.py requires."""
    return [
        Text("BUS IN", *bus_in, 0.8),
        Text("BUS OUT", 44.3, 18.35, 0.8),
        Text("TERM", 29.8, 7.8, 0.8),
        *[Text(label, x, 12.55, 0.8) for label, x in (("5V", 26.0), ("H", 28.54), ("L", 31.08),
                                                        ("G", 33.62))],
        Text(f"R2P {name.upper()}", 30.0, 32.0, 2.0, "B.SilkS"),
        Text(f"rev {revision}", 30.0, 35.0, 1.2, "B.SilkS"),
        Text("BUS IN", 15.9, 10.0, 1.2, "B.SilkS"),    # under J1 (mirrored text, same place)
        Text("BUS OUT", 44.3, 10.0, 1.2, "B.SilkS"),
    ]
