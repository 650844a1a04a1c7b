"""hardware/motor's off-board heatsink: the sink-to-air thermal resistance of a plate-fin extrusion
in natural convection, from its geometry, and the smallest simple extrusion that meets the
requirement calc/motor.py sets (`HEATSINK_RTH`, `HEATSINK_J_PER_K`).

Run `scripts/py -m r2ptools.kicad.calc.heatsink` for the required geometry, its R_th, mass, heat
capacity and margin, and what the model says of the candidate part's envelope (`--readme` writes
them into hardware/motor/README.md's heatsink section).

Why a model: no heatsink maker's sheet could be read on the machines this was written on (the
candidate's R_th is a distributor's field, NOT VERIFIED), and a catalogue R_th is stated at the
maker's own temperature rise, usually far above this board's ~20 K: natural convection and
radiation both weaken as the rise falls, so the same sink is worse here than on its sheet. The
model gives the number at this board's own loss, ambient and mounting.

The model (one concept: heat from the sink's mounting face to still air):
- Channels between fins: Bar-Cohen & Rohsenow (1984, "Thermally optimum spacing of vertical,
  natural convection cooled, parallel plates", J. Heat Transfer 106:116) composite correlation for
  symmetric isothermal plates, Nu_S = h S / k = [576 / El² + 2.873 / El^½]^-½ with the Elenbaas
  number El = Ra_S S / L (Elenbaas 1942, "Heat dissipation of parallel plates by free
  convection", Physica 9:1). Its small-El limit is Elenbaas's fully developed channel, El / 24;
  its large-El limit an isolated plate, 0.59 El^¼; its optimum spacing 2.714 L Ra_L^-¼ with
  Nu 1.307 (Incropera & DeWitt, Fundamentals of Heat and Mass Transfer, §9.7, Eqs. 9.45-9.48;
  Çengel, Heat and Mass Transfer, §9-6). The channel coefficient also applies to the base
  between the fins (an assumption: it sees the same channel flow; Çengel's example counts the
  fins alone).
- The two outer faces of the end fins: an isolated vertical plate, Churchill & Chu's laminar
  correlation Nu_L = 0.68 + 0.670 Ra_L^¼ / [1 + (0.492/Pr)^(9/16)]^(4/9) (Incropera Eq. 9.27).
- Fins: efficiency tanh(m L_c) / (m L_c), m = √(2 h / (k t)), corrected length L_c = H + t/2 for
  the tip's convection (Incropera Eq. 3.89 and Table 3.4).
- Radiation: the sink's envelope (the fin-tip face W × L and the two side faces L × (H + base)),
  black-anodised, emissivity `EMISSIVITY`, to surroundings at the ambient, at the fins' mean
  excess temperature η ΔT; the channels' ends and the back of the base (against the case) are
  left out: conservative.
- The base: heat enters through the case's aluminium blocks (`SOURCE_MM`, their footprints from
  enclosures/motor/motor.json), not the whole base; the
  spreading resistance is Lee, Song, Au & Moran's closed form for a source on a plate cooled by
  a uniform coefficient ("Constriction/spreading resistance model for electronics packaging",
  ASME/JSME Thermal Engineering Conference 1995), taken at the source's centre (ψ_max: the
  hottest point, conservative), the fins' coefficient spread over the base as h_eff.
- Air: properties at the film temperature (base and ambient), interpolated in Incropera &
  DeWitt's Table A.4 (air at 1 atm; 250-400 K rows as remembered: NOT VERIFIED against the printed
  table; tests/test_heatsink.py finds them within 3 % of Çengel's Table A-15 at 55 °C);
  β = 1/T_film (ideal gas).

Not modelled, and the README says so: a sink whose fins are not vertical (a module lying flat
with its sink hanging under it is a downward-facing array, markedly worse), nearby walls or
enclosures that choke the channels' inflow, dust.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

G = 9.80665                   # m/s², standard gravity
SIGMA = 5.670374419e-8        # W/(m²·K⁴), Stefan-Boltzmann (CODATA 2018)
KELVIN = 273.15

# Air at 1 atm, Incropera & DeWitt Table A.4 (NOT VERIFIED against the printed table: see above):
# T (K), ν (m²/s), k (W/(m·K)), α (m²/s). Pr = ν / α.
AIR_TABLE = (
    (250.0, 11.44e-6, 22.3e-3, 15.9e-6),
    (300.0, 15.89e-6, 26.3e-3, 22.5e-6),
    (350.0, 20.92e-6, 30.0e-3, 29.9e-6),
    (400.0, 26.41e-6, 33.8e-3, 38.3e-6),
)

# Aluminium extrusion alloy (EN AW-6060/6063 class, what extruded sinks are made of): k 200 W/(m·K)
# is the low end of the 200-210 usually given for the T5/T6 tempers (estimate, NOT VERIFIED
# against EN 755); density and specific heat as Incropera Table A.1 gives pure aluminium
# (2702 kg/m³, 903 J/(kg·K) at 300 K), rounded down.
AL_K = 200.0
AL_RHO = 2700.0
AL_CP = 900.0
EMISSIVITY = 0.80             # black anodised: anodised aluminium 0.82 at 300 K (Çengel's and
                              # Incropera's emissivity tables, as remembered), taken lower

# --- what the motor module asks (calc/motor.py, the case and the board) -------------------------
T_AMB = 40.0                  # °C, issue 19's ambient (calc/motor.py T_AMB)
CASE_JSON = Path(__file__).resolve().parents[4] / "enclosures/motor/motor.json"


def case_heat_path() -> dict:
    """The motor case's heat path (enclosures/motor/motor.json `heat_path`: made by
    scripts/enclosures from the board, r2ptools/enclosure/heatpath.py)."""
    try:
        return json.loads(CASE_JSON.read_text())["case"]["heat_path"]
    except (OSError, KeyError, ValueError) as e:
        raise ValueError(f"{CASE_JSON}: no heat path ({e}): run scripts/enclosures generate motor") from None


def case_source_mm() -> tuple[float, float]:
    """Where the heat enters the sink's base: the case's aluminium blocks' footprints, as one
    rectangle of their summed area and their length (the spreading model takes the area)."""
    bl = case_heat_path()["blocks"]
    length = max(b["box"][4] - b["box"][1] for b in bl)
    area = sum((b["box"][3] - b["box"][0]) * (b["box"][4] - b["box"][1]) for b in bl)
    return round(area / length, 4), round(length, 4)


SOURCE_MM = case_source_mm()  # the blocks under the four D2PAK tab islands: where the heat enters the base
MOUNT_MM = (60.0, 50.0)       # smallest base: the board's four M3 holes (52 × 42 mm) plus 4 mm of
                              # base beyond each hole's centre
FOOTPRINT_MAX_MM = (110.0, 100.0)   # largest base along the board's x and y: in x between the bus
                              # end's M5 floor mounts (x ≤ 50 mm, enclosures/motor/motor.json) and the
                              # case's right wall (x 164 mm); in y the 55 mm case plus ~22 mm a side
MARGIN = 0.20                 # the model must come 20 % under the requirement: the correlation's
                              # scatter against the data it was fitted to (~10 %: an estimate), the
                              # remembered property and emissivity figures, a real profile's tapered
                              # fins and rough surface


@dataclass(frozen=True)
class Air:
    """Air's properties at one film temperature."""
    t_film: float             # K
    nu: float                 # kinematic viscosity, m²/s
    k: float                  # thermal conductivity, W/(m·K)
    alpha: float              # thermal diffusivity, m²/s

    @property
    def pr(self) -> float:
        return self.nu / self.alpha

    @property
    def beta(self) -> float:
        return 1.0 / self.t_film

    def rayleigh(self, length: float, dt: float) -> float:
        """g β ΔT L³ / (ν α)."""
        return G * self.beta * dt * length ** 3 / (self.nu * self.alpha)


def air(t_film_k: float) -> Air:
    """Air's properties at `t_film_k` (K), linear between the table's rows."""
    lo, hi = AIR_TABLE[0][0], AIR_TABLE[-1][0]
    if not lo <= t_film_k <= hi:
        raise ValueError(f"film temperature {t_film_k - KELVIN:.1f} °C is outside the air table's "
                         f"{lo - KELVIN:.0f}-{hi - KELVIN:.0f} °C (Incropera Table A.4 rows in "
                         "AIR_TABLE): extend the table before modelling there")
    for (t0, *a), (t1, *b) in zip(AIR_TABLE, AIR_TABLE[1:]):
        if t0 <= t_film_k <= t1:
            f = (t_film_k - t0) / (t1 - t0)
            nu, k, alpha = (x + f * (y - x) for x, y in zip(a, b))
            return Air(t_film_k, nu, k, alpha)
    raise AssertionError("unreachable: the table's rows are ordered")


def channel_nusselt(elenbaas: float) -> float:
    """Bar-Cohen & Rohsenow's composite Nusselt number h S / k of a channel between symmetric
    isothermal vertical plates, from the Elenbaas number Ra_S S / L."""
    return (576.0 / elenbaas ** 2 + 2.873 / math.sqrt(elenbaas)) ** -0.5


def channel_h(spacing: float, length: float, dt: float, a: Air) -> float:
    """The channels' heat transfer coefficient, W/(m²·K), at `spacing` (m) between fins
    `length` (m) tall, `dt` (K) above the ambient."""
    el = a.rayleigh(spacing, dt) * spacing / length
    return channel_nusselt(el) * a.k / spacing


def optimum_spacing(length: float, dt: float, a: Air) -> float:
    """Bar-Cohen & Rohsenow's optimum spacing of isothermal plates, 2.714 L Ra_L^-¼ (m): the one
    that sheds the most heat from a given volume of thin fins."""
    return 2.714 * length / a.rayleigh(length, dt) ** 0.25


def plate_h(length: float, dt: float, a: Air) -> float:
    """An isolated vertical plate, Churchill & Chu laminar (Ra_L ≤ 1e9): W/(m²·K)."""
    ra = a.rayleigh(length, dt)
    if ra > 1e9:
        raise ValueError(f"Ra_L {ra:.2e} > 1e9: the laminar correlation does not hold; use "
                         "Churchill & Chu's full-range form")
    nu = 0.68 + 0.670 * ra ** 0.25 / (1 + (0.492 / a.pr) ** (9 / 16)) ** (4 / 9)
    return nu * a.k / length


def fin_efficiency(h: float, k: float, thickness: float, height: float) -> float:
    """tanh(m L_c) / (m L_c) of a straight rectangular fin, tip convection by L_c = H + t/2."""
    lc = height + thickness / 2
    ml = math.sqrt(2 * h / (k * thickness)) * lc
    return math.tanh(ml) / ml


def spreading_resistance(source_m2: float, plate_m2: float, thickness: float, k: float,
                         h_eff: float) -> float:
    """Lee, Song, Au & Moran (1995): the resistance from a source's centre through a plate of
    `thickness` to its cooled face (1-D conduction included), equivalent circles for both areas,
    `h_eff` the cooling spread over the plate's face. K/W."""
    a, b = math.sqrt(source_m2 / math.pi), math.sqrt(plate_m2 / math.pi)
    eps, tau = a / b, thickness / b
    bi = h_eff * b / k
    lam = math.pi + 1 / (math.sqrt(math.pi) * eps)
    phi = (math.tanh(lam * tau) + lam / bi) / (1 + lam / bi * math.tanh(lam * tau))
    psi = eps * tau / math.sqrt(math.pi) + (1 - eps) * phi / math.sqrt(math.pi)
    return psi / (math.sqrt(math.pi) * k * a)


@dataclass(frozen=True)
class Sink:
    """A plate-fin extrusion standing with its fins vertical: `width` across the fins, `length`
    along them (the height the air rises), a `base` plate, `fins` fins of `fin_t` thickness and
    `fin_h` height above the base, the two outer fins flush with the base's edges. Metres."""
    width: float
    length: float
    base: float
    fins: int
    fin_t: float
    fin_h: float

    def __post_init__(self):
        for name in ("width", "length", "base", "fin_t", "fin_h"):
            if not getattr(self, name) > 0:
                raise ValueError(f"heatsink {name} {getattr(self, name)!r} m: must be positive")
        if not isinstance(self.fins, int) or self.fins < 2:
            raise ValueError(f"heatsink fins {self.fins!r}: a plate-fin sink needs at least 2 fins")
        if self.spacing <= 0:
            raise ValueError(f"heatsink of {self.fins} fins × {self.fin_t * 1e3:g} mm does not fit "
                             f"its {self.width * 1e3:g} mm width: fewer or thinner fins")

    @property
    def spacing(self) -> float:
        """The gap between neighbouring fins."""
        return (self.width - self.fins * self.fin_t) / (self.fins - 1)

    @property
    def mass(self) -> float:
        """kg of aluminium."""
        return AL_RHO * self.length * (self.width * self.base + self.fins * self.fin_t * self.fin_h)

    @property
    def heat_capacity(self) -> float:
        """J/K."""
        return self.mass * AL_CP

    @property
    def envelope(self) -> tuple[float, float, float]:
        """Width × length × overall height (base and fins), m."""
        return self.width, self.length, self.base + self.fin_h

    def describe(self) -> str:
        w, l, h = (x * 1e3 for x in self.envelope)
        return (f"{w:g} × {l:g} × {h:g} mm: {self.base * 1e3:g} mm base, {self.fins} fins "
                f"{self.fin_t * 1e3:g} × {self.fin_h * 1e3:g} mm, {self.spacing * 1e3:.1f} mm gaps")


@dataclass(frozen=True)
class Heat:
    """What a sink sheds at a base temperature rise, and how."""
    dt: float                 # base above ambient, K
    channels: float           # W, channel faces and the base between the fins
    outer: float              # W, the end fins' outer faces
    radiation: float          # W
    h_channel: float          # W/(m²·K)
    eta: float                # inner fins' efficiency

    @property
    def total(self) -> float:
        return self.channels + self.outer + self.radiation


def shed(sink: Sink, dt: float, t_amb: float = T_AMB) -> Heat:
    """Heat to air and surroundings from `sink` with its base `dt` K above `t_amb` °C."""
    ta = t_amb + KELVIN
    a = air(ta + dt / 2)
    s, l, lc = sink.spacing, sink.length, sink.fin_h + sink.fin_t / 2
    h_ch = channel_h(s, l, dt, a)
    h_out = plate_h(l, dt, a)
    eta = fin_efficiency(h_ch, AL_K, sink.fin_t, sink.fin_h)
    eta_end = fin_efficiency((h_ch + h_out) / 2, AL_K, sink.fin_t, sink.fin_h)
    n = sink.fins
    channels = dt * h_ch * ((n - 1) * s * l + (n - 2) * eta * 2 * lc * l + 2 * eta_end * lc * l)
    outer = dt * 2 * eta_end * h_out * lc * l
    envelope = sink.width * l + 2 * l * (sink.fin_h + sink.base)
    t_rad = ta + eta * dt
    radiation = EMISSIVITY * SIGMA * envelope * (t_rad ** 4 - ta ** 4)
    return Heat(dt, channels, outer, radiation, h_ch, eta)


@dataclass(frozen=True)
class Result:
    """A sink at one power: its resistance from the source's centre to the ambient, and parts."""
    sink: Sink
    power: float              # W
    t_amb: float              # °C
    heat: Heat                # at the base's mean rise
    r_spread: float           # K/W, source centre to the base's cooled face (1-D included)

    @property
    def r_fins(self) -> float:
        return self.heat.dt / self.power

    @property
    def r(self) -> float:
        """Sink to air, K/W: what calc/motor.py calls HEATSINK_RTH."""
        return self.r_fins + self.r_spread


def resistance(sink: Sink, power: float, t_amb: float = T_AMB,
               source_mm: tuple[float, float] = SOURCE_MM) -> Result:
    """`sink` shedding `power` W at `t_amb` °C through a `source_mm` footprint: the base's rise
    found by bisection (what the sink sheds grows with it), then the spreading in the base."""
    if not power > 0:
        raise ValueError(f"heatsink power {power!r} W: must be positive")
    lo, hi = 1e-6, 160.0
    if shed(sink, hi, t_amb).total < power:
        raise ValueError(f"{sink.describe()} cannot shed {power:g} W below a {hi:.0f} K rise")
    for _ in range(36):           # 160 K / 2³⁶: 2 nK
        mid = (lo + hi) / 2
        if shed(sink, mid, t_amb).total < power:
            lo = mid
        else:
            hi = mid
    heat = shed(sink, hi, t_amb)
    plate = sink.width * sink.length
    h_eff = power / (heat.dt * plate)
    source = source_mm[0] * source_mm[1] * 1e-6
    if source > plate:
        raise ValueError(f"the {source_mm[0]} × {source_mm[1]} mm source is larger than the "
                         f"{sink.describe()} base")
    r_sp = spreading_resistance(source, plate, sink.base, AL_K, h_eff)
    return Result(sink, power, t_amb, heat, r_sp)


# --- the required geometry ---------------------------------------------------------------------
# A "simple extrusion": a 6 mm base (an M3 thread's 1.5 d of engagement, and room to spread the
# window's heat), 2 mm fins (extruded fins this tall are rarely thinner), gaps ≥ 4 mm and fins at
# most 10 × their gap tall (the usual limits of an extrusion die's tongue: estimates), a base at
# least MOUNT_MM. Searched on a 10 mm grid of width and length and 5 mm of fin height, every fin
# count; "smallest" is the least envelope volume (it has to fit under the module), then mass.
BASE_T = 6e-3
FIN_T = 2e-3
MIN_GAP = 4e-3
MAX_ASPECT = 10.0
WIDTHS_MM = tuple(range(60, 151, 10))
LENGTHS_MM = tuple(range(50, 151, 10))
FIN_HEIGHTS_MM = tuple(range(10, 61, 5))


def extrusions(width_mm: float, length_mm: float, fin_h_mm: float):
    """Every fin count of one envelope that the extrusion limits allow."""
    w, fh = width_mm * 1e-3, fin_h_mm * 1e-3
    for n in range(2, int(w / FIN_T)):
        gap = (w - n * FIN_T) / (n - 1)
        if gap < MIN_GAP:
            break
        if fh / gap <= MAX_ASPECT:
            yield Sink(w, length_mm * 1e-3, BASE_T, n, FIN_T, fh)


def fits(width_mm: float, length_mm: float) -> bool:
    """A base of `width_mm` × `length_mm` covers the M3 rectangle and fits under the module one
    way round or the other (fins along the board's y, or along its x)."""
    mx, my = FOOTPRINT_MAX_MM
    return (min(width_mm, length_mm) >= MOUNT_MM[1] and max(width_mm, length_mm) >= MOUNT_MM[0]
            and ((width_mm <= mx and length_mm <= my) or (length_mm <= mx and width_mm <= my)))


def orientation(sink: Sink) -> str:
    """Which way `sink` fits under the module (FOOTPRINT_MAX_MM), and so how the module must stand
    for its fins to be vertical."""
    w, l = sink.width * 1e3, sink.length * 1e3
    if w <= FOOTPRINT_MAX_MM[0] and l <= FOOTPRINT_MAX_MM[1]:
        return ("fins along the board's y: the module stands with its long side horizontal, "
                "board vertical")
    return "fins along the board's x: the module stands on its end, long side vertical"


@lru_cache(maxsize=8)          # rows() asks once per board loss; clear it after changing a constant
def smallest(power: float, limit: float, j_per_k: float, t_amb: float = T_AMB,
             margin: float = MARGIN) -> Result:
    """The smallest simple extrusion (above) whose modelled R_th at `power` W and `t_amb` °C is
    ≤ `limit` × (1 − `margin`) and whose heat capacity is ≥ `j_per_k`."""
    target = limit * (1 - margin)
    envelopes = sorted(((w, l, h) for w in WIDTHS_MM for l in LENGTHS_MM if fits(w, l)
                        for h in FIN_HEIGHTS_MM),
                       key=lambda e: (e[0] * e[1] * (e[2] + BASE_T * 1e3), e))
    for w, l, h in envelopes:
        best = None
        for sink in extrusions(w, l, h):
            if sink.heat_capacity < j_per_k:
                continue
            res = resistance(sink, power, t_amb)
            if res.r <= target and (best is None or sink.mass < best.sink.mass):
                best = res
        if best is not None:
            return best
    raise ValueError(f"no extrusion up to {WIDTHS_MM[-1]} × {LENGTHS_MM[-1]} × "
                     f"{FIN_HEIGHTS_MM[-1] + BASE_T * 1e3:g} mm meets {target:.2f} K/W at {power:g} W: "
                     "widen the search or forced air")


def best_in_envelope(width_mm: float, length_mm: float, height_mm: float, power: float,
                     t_amb: float = T_AMB) -> Result:
    """The lowest-R_th fin count, under the same extrusion limits, of an envelope: what a
    catalogue part of that size can at best do by this model when its own profile is not known."""
    results = [resistance(s, power, t_amb)
               for s in extrusions(width_mm, length_mm, height_mm - BASE_T * 1e3)]
    if not results:
        raise ValueError(f"no extrusion fits {width_mm} × {length_mm} × {height_mm} mm")
    return min(results, key=lambda r: r.r)


# The candidate (hardware/motor/off-board.csv): Fischer Elektronik SK 88 100 SA, "100 x 100 x 50
# mm" by the distributors' fields; its profile (fin count, fin and base thickness) NOT VERIFIED.
CANDIDATE = "Fischer Elektronik SK 88 100 SA"
CANDIDATE_MM = (100.0, 100.0, 50.0)
CANDIDATE_DISTRIBUTOR_RTH = (1.05, 0.85)   # °C/W: Digi-Key's and RS's fields (NOT VERIFIED)


def report(power: float, limit: float, j_per_k: float, t_amb: float = T_AMB) -> list[str]:
    """The lines `main` prints: the required geometry and the candidate's envelope."""
    req = smallest(power, limit, j_per_k, t_amb)
    s, h = req.sink, req.heat
    out = [f"heatsink at {power:.1f} W, {t_amb:.0f} °C ambient, fins vertical, still air "
           f"(r2ptools/kicad/calc/heatsink.py)", "",
           f"required: ≤ {limit:.2f} °C/W with a {MARGIN:.0%} margin (model ≤ {limit * (1 - MARGIN):.2f}), "
           f"≥ {j_per_k:.0f} J/K, base ≥ {MOUNT_MM[0]:g} × {MOUNT_MM[1]:g} mm and at most "
           f"{FOOTPRINT_MAX_MM[0]:g} mm along the board's x, {FOOTPRINT_MAX_MM[1]:g} mm along its y",
           f"smallest simple extrusion: {s.describe()}",
           f"  {orientation(s)}",
           f"  R_th {req.r:.2f} °C/W = fins to air {req.r_fins:.2f} + spreading in the base "
           f"{req.r_spread:.2f}; margin {1 - req.r / limit:.0%} under {limit:.1f}",
           f"  base {h.dt:.1f} K above the ambient: channels {h.channels:.2f} W (h {h.h_channel:.2f} "
           f"W/(m²·K), fin efficiency {h.eta:.2f}), outer faces {h.outer:.2f} W, radiation "
           f"{h.radiation:.2f} W (ε {EMISSIVITY})",
           f"  mass {s.mass * 1e3:.0f} g, heat capacity {s.heat_capacity:.0f} J/K (≥ {j_per_k:.0f})"]
    cand = best_in_envelope(*CANDIDATE_MM, power, t_amb)
    hot = best_in_envelope(*CANDIDATE_MM, 75.0 / cand.r, t_amb)
    out += ["", f"candidate {CANDIDATE}, envelope {' × '.join(f'{x:g}' for x in CANDIDATE_MM)} mm "
            "(profile NOT VERIFIED): its best plate-fin profile by this model",
            f"  {cand.sink.describe()}: R_th {cand.r:.2f} °C/W at {power:.1f} W; "
            f"{hot.r:.2f} °C/W at a ~75 K rise ({hot.power:.0f} W)",
            f"  distributors' fields {CANDIDATE_DISTRIBUTOR_RTH[0]} / {CANDIDATE_DISTRIBUTOR_RTH[1]} "
            "°C/W (Digi-Key / RS; conditions not read): a catalogue figure at a large rise is lower "
            "than the same sink at this board's"]
    return out


README_BEGIN = "<!-- BEGIN generated by scripts/py -m r2ptools.kicad.calc.heatsink --markdown: do not edit -->"
README_END = "<!-- END generated heatsink -->"


def motor_report() -> list[str]:
    """`report` for the motor board: its loss, requirement and heat capacity (calc/motor.py)."""
    from . import motor
    return report(round(motor.board_loss(), 6), motor.HEATSINK_RTH, motor.HEATSINK_J_PER_K, motor.T_AMB)


def markdown() -> str:
    """The report as hardware/motor/README.md embeds it (tests/test_heatsink.py keeps it current)."""
    return "\n".join([README_BEGIN, "", "```text", *motor_report(), "```", "", README_END])


def readme_with_report(text: str) -> str:
    """`text` (hardware/motor/README.md) with its generated heatsink block replaced."""
    try:
        head, rest = text.split(README_BEGIN, 1)
        _, tail = rest.split(README_END, 1)
    except ValueError:
        raise ValueError(f"hardware/motor/README.md: the markers {README_BEGIN!r} … {README_END!r} are "
                         "missing: put them where the heatsink's numbers go") from None
    return head + markdown() + tail


def main(argv: list[str] | None = None) -> int:
    import sys
    from . import motor
    argv = sys.argv[1:] if argv is None else argv
    if argv == ["--markdown"]:
        print(markdown())
        return 0
    if argv == ["--readme"]:
        motor.README.write_text(readme_with_report(motor.README.read_text()))
        return 0
    if argv:
        print("usage: scripts/py -m r2ptools.kicad.calc.heatsink [--markdown | --readme]", file=sys.stderr)
        return 2
    print("\n".join(motor_report()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
