"""hardware/motor's heatsink model (r2ptools/kicad/calc/heatsink.py): the correlations against a
textbook's worked example and their own limits, the physics' directions, the required geometry,
and bad input named. Each numeric check would fail if a constant of a correlation were changed."""
from __future__ import annotations

import math

import pytest

from r2ptools.kicad.calc import heatsink as hs
from r2ptools.kicad.calc import motor

# Çengel & Ghajar, Heat and Mass Transfer (§9-6, the worked example "Optimum fin spacing of a heat
# sink"; as remembered, not read here): a 12 cm wide, 18 cm tall vertical surface at 80 °C in 30 °C
# air, fins 1 mm thick, 2.4 cm tall, 18 cm long, taken as isothermal. Air at the 55 °C film from
# the book's Table A-15: k 0.02772 W/(m·K), ν 1.847e-5 m²/s, Pr 0.7215; β = 1/328 K.
# Worked by hand: Ra_L = 9.81 × (1/328) × 50 × 0.18³ / (1.847e-5)² × 0.7215 = 1.845e7;
# S_opt = 2.714 × 0.18 / Ra_L^¼ = 2.714 × 0.18 / 65.54 = 7.45 mm; n = 0.12 / (7.45 + 1) mm = 14;
# Nu = 1.307 → h = 1.307 × 0.02772 / 7.45e-3 = 4.86 W/(m²·K); Q = h × 2 n L H × ΔT
# = 4.86 × (2 × 14 × 0.18 × 0.024 m²) × 50 K = 29.4 W (the book's answer as remembered).
CENGEL_AIR = hs.Air(328.15, 1.847e-5, 0.02772, 1.847e-5 / 0.7215)


def test_cengels_worked_example():
    a = hs.Air(328.0, CENGEL_AIR.nu, CENGEL_AIR.k, CENGEL_AIR.alpha)   # the book takes β = 1/328 K
    length, dt = 0.18, 50.0
    assert a.rayleigh(length, dt) == pytest.approx(1.845e7, rel=2e-3)
    s = hs.optimum_spacing(length, dt, a)
    assert s == pytest.approx(7.45e-3, rel=3e-3)
    n = int(0.12 / (s + 1e-3))
    assert n == 14
    h = hs.channel_h(s, length, dt, a)
    assert h == pytest.approx(4.86, rel=3e-3)
    assert h * 2 * n * length * 0.024 * dt == pytest.approx(29.4, rel=5e-3)


def test_the_correlation_meets_its_two_limits():
    """Elenbaas's fully developed channel at small El (Nu = El/24), an isolated plate at large El
    (Nu = 0.59 El^¼): the composite's two constants are these limits' (576 = 24², 0.59 = 2.873^-½)."""
    for el in (1e-3, 1e-2):
        assert hs.channel_nusselt(el) == pytest.approx(el / 24, rel=2e-3)
    for el in (1e8, 1e10):
        assert hs.channel_nusselt(el) == pytest.approx(0.59 * el ** 0.25, rel=5e-3)


def test_the_optimum_spacing_maximises_heat_per_width():
    """Thin isothermal fins in a fixed width shed ∝ (1/S) h(S): its maximum is 2.714 L Ra_L^-¼,
    where Nu is 1.307 (Bar-Cohen & Rohsenow)."""
    a = hs.air(hs.KELVIN + 50.0)
    length, dt = 0.1, 20.0
    spacings = [i * 1e-5 for i in range(200, 3000)]
    best = max(spacings, key=lambda s: hs.channel_h(s, length, dt, a) / s)
    s_opt = hs.optimum_spacing(length, dt, a)
    assert best == pytest.approx(s_opt, rel=5e-3)
    el = a.rayleigh(s_opt, dt) * s_opt / length
    assert hs.channel_nusselt(el) == pytest.approx(1.307, abs=2e-3)


def test_the_air_table_agrees_with_a_second_textbook():
    """Incropera's Table A.4 interpolated at 55 °C against Çengel's Table A-15 (within 3 %)."""
    a = hs.air(hs.KELVIN + 55.0)
    assert a.nu == pytest.approx(CENGEL_AIR.nu, rel=0.03)
    assert a.k == pytest.approx(CENGEL_AIR.k, rel=0.03)
    assert a.pr == pytest.approx(0.7215, rel=0.03)
    assert a.beta == pytest.approx(1 / 328.15)


def test_an_isolated_plate_by_hand():
    """Churchill & Chu laminar, worked by hand for a 0.1 m plate 20 K above 40 °C air."""
    a = hs.air(hs.KELVIN + 50.0)
    ra = 9.80665 / a.t_film * 20 * 0.1 ** 3 / (a.nu * a.alpha)
    nu = 0.68 + 0.670 * ra ** 0.25 / (1 + (0.492 / a.pr) ** (9 / 16)) ** (4 / 9)
    assert hs.plate_h(0.1, 20.0, a) == pytest.approx(nu * a.k / 0.1, rel=1e-9)
    assert 3.0 < hs.plate_h(0.1, 20.0, a) < 6.0        # the usual few W/(m²·K) of still air


def test_fin_efficiency_by_hand():
    # m = √(2 × 5 / (200 × 0.002)) = 5 /m; L_c = 0.061 m; tanh(0.305) / 0.305 = 0.9702
    assert hs.fin_efficiency(5.0, 200.0, 2e-3, 0.06) == pytest.approx(0.9702, abs=2e-4)
    assert hs.fin_efficiency(5.0, 200.0, 2e-3, 0.001) == pytest.approx(1.0, abs=1e-3)
    assert hs.fin_efficiency(5.0, 20.0, 2e-3, 0.06) < 0.8     # a poor conductor: a poor fin


def test_spreading_is_one_dimensional_when_the_source_covers_the_base():
    t, k, area = 6e-3, 200.0, 0.1 * 0.1
    assert hs.spreading_resistance(area, area, t, k, 10.0) == pytest.approx(t / (k * area), rel=1e-9)
    small = hs.spreading_resistance(0.04 * 0.034, area, t, k, 10.0)
    assert small > 3 * t / (k * area)
    assert hs.spreading_resistance(0.04 * 0.034, area, 2 * t, k, 10.0) < small   # a thicker base spreads


SINK = hs.Sink(0.1, 0.1, 6e-3, 10, 2e-3, 0.044)


def test_taller_fins_shed_more():
    rs = [hs.resistance(hs.Sink(0.1, 0.1, 6e-3, 10, 2e-3, h * 1e-3), 10.0).r for h in range(10, 61, 5)]
    assert all(a > b for a, b in zip(rs, rs[1:])), rs


def test_a_fin_count_optimum_exists():
    rs = {n: hs.resistance(hs.Sink(0.1, 0.1, 6e-3, n, 2e-3, 0.044), 10.0).r for n in range(3, 30)}
    best = min(rs, key=rs.get)
    assert 3 < best < 29 and rs[3] > rs[best] < rs[29], rs
    # the optimum gap is near Bar-Cohen's for isothermal plates (the fins are ~97 % efficient)
    res = hs.resistance(hs.Sink(0.1, 0.1, 6e-3, best, 2e-3, 0.044), 10.0)
    a = hs.air(hs.KELVIN + hs.T_AMB + res.heat.dt / 2)
    assert res.sink.spacing == pytest.approx(hs.optimum_spacing(0.1, res.heat.dt, a), rel=0.25)


def test_a_sink_is_better_at_a_larger_rise():
    """Convection and radiation grow faster than the rise: why a catalogue's R_th, stated at a
    large rise, flatters a sink at this board's ~15 K."""
    low, high = hs.resistance(SINK, 10.0), hs.resistance(SINK, 40.0)
    assert high.heat.dt > 2.5 * low.heat.dt
    assert high.r < 0.85 * low.r


def test_radiation_counts(monkeypatch):
    with_rad = hs.resistance(SINK, 10.0)
    assert 0.1 < with_rad.heat.radiation / 10.0 < 0.3
    monkeypatch.setattr(hs, "EMISSIVITY", 0.0)
    assert hs.resistance(SINK, 10.0).r > 1.1 * with_rad.r


def test_the_heat_balances():
    res = hs.resistance(SINK, 10.0)
    assert res.heat.total == pytest.approx(10.0, rel=1e-6)
    assert res.r == pytest.approx(res.heat.dt / 10.0 + res.r_spread)


def test_mass_and_heat_capacity():
    # 0.1 × (0.1 × 0.006 + 10 × 0.002 × 0.044) m³ = 1.48e-4 m³ → 399.6 g, 359.6 J/K
    assert SINK.mass == pytest.approx(0.3996, rel=1e-6)
    assert SINK.heat_capacity == pytest.approx(359.64, rel=1e-6)


def test_the_required_geometry_is_the_smallest_that_meets_the_requirement():
    req = motor.required_heatsink()
    limit = motor.HEATSINK_RTH * (1 - hs.MARGIN)
    assert req.r <= limit and req.sink.heat_capacity >= motor.HEATSINK_J_PER_K
    w, l, h = (round(x * 1e3) for x in req.sink.envelope)
    assert hs.fits(w, l)
    volume = w * l * h
    # every envelope of the search grid with less volume fails at every fin count
    for w2 in hs.WIDTHS_MM:
        for l2 in hs.LENGTHS_MM:
            for fh in hs.FIN_HEIGHTS_MM:
                if hs.fits(w2, l2) and w2 * l2 * (fh + hs.BASE_T * 1e3) < volume:
                    for s in hs.extrusions(w2, l2, fh):
                        assert not (hs.resistance(s, req.power).r <= limit
                                    and s.heat_capacity >= motor.HEATSINK_J_PER_K), s


def test_the_junction_row_runs_on_the_model(monkeypatch):
    """The modelled T_J row's number is the junction on the required sink's modelled resistance
    (not a typed one): a worse model moves it; a model no extrusion can satisfy fails the rows."""
    def row():
        (r,) = [r for r in motor.rows() if r.what.startswith("T_J worst FET on the required extrusion")]
        return r
    req = motor.required_heatsink()
    tj, _ = motor.junction(motor.I_CONT, motor.VIN_MAX, motor.modelled_sink(req.sink))
    assert row().value == f"{tj:.0f} °C" and f"modelled {req.r:.2f} °C/W" in row().note
    assert tj < motor.junction(motor.I_CONT, motor.VIN_MAX, motor.HEATSINK_RTH)[0]
    worse = motor.modelled_sink
    monkeypatch.setattr(motor, "modelled_sink", lambda sink: lambda total: 1.5 * worse(sink)(total))
    assert float(row().value.split()[0]) >= tj + 5
    hs.smallest.cache_clear()
    monkeypatch.setattr(hs, "EMISSIVITY", 0.0)   # bare metal: no extrusion of the search meets 1.6 °C/W
    try:
        failing = [r for r in motor.rows() if not r.ok and "traded" not in r.note]
        assert [r.what.split(" (")[0] for r in failing] == [
            "heatsink: smallest extrusion for ≤ 2.0 °C/W", f"heatsink candidate {hs.CANDIDATE}",
            "T_J worst FET on the required extrusion at 20 A, 40 °C"]
        assert "no extrusion up to" in failing[0].note
    finally:
        hs.smallest.cache_clear()


def test_the_candidates_model_meets_the_requirement():
    (r,) = [r for r in motor.rows() if r.what.startswith("heatsink candidate")]
    assert r.ok and "NOT VERIFIED" in r.note


@pytest.mark.parametrize("make, message", [
    (lambda: hs.Sink(0.05, 0.1, 6e-3, 30, 2e-3, 0.04), "does not fit its 50 mm width"),
    (lambda: hs.Sink(0.1, 0.1, 6e-3, 1, 2e-3, 0.04), "at least 2 fins"),
    (lambda: hs.Sink(0.1, -0.1, 6e-3, 5, 2e-3, 0.04), "heatsink length -0.1 m: must be positive"),
    (lambda: hs.air(hs.KELVIN + 200.0), "outside the air table"),
    (lambda: hs.resistance(SINK, 0.0), "must be positive"),
    (lambda: hs.resistance(SINK, 10.0, source_mm=(120.0, 120.0)), "larger than"),
    (lambda: hs.resistance(hs.Sink(0.06, 0.05, 3e-3, 2, 2e-3, 0.005), 200.0), "cannot shed 200 W"),
])
def test_bad_input_is_named(make, message):
    with pytest.raises(ValueError, match=message):
        make()


def test_main_prints_the_required_geometry_and_the_candidate(capsys):
    assert hs.main([]) == 0
    out = capsys.readouterr().out
    req = motor.required_heatsink()
    assert req.sink.describe() in out and f"R_th {req.r:.2f} °C/W" in out
    assert hs.CANDIDATE in out and "NOT VERIFIED" in out
    assert hs.main(["--bogus"]) == 2
    assert hs.main(["--markdown"]) == 0 and hs.README_BEGIN in capsys.readouterr().out


def test_the_constants_are_the_documented_ones():
    """The correlation's and the air table's numbers, spelled out (a changed digit is caught by
    the worked examples above too)."""
    assert hs.channel_nusselt(1.0) == pytest.approx((576 + 2.873) ** -0.5)
    assert math.isclose(hs.AIR_TABLE[1][1], 15.89e-6) and math.isclose(hs.AIR_TABLE[2][2], 30.0e-3)


def test_the_readme_heatsink_block_is_the_scripts_output():
    text = motor.README.read_text()
    assert hs.readme_with_report(text) == text, \
        "hardware/motor/README.md is stale: run scripts/py -m r2ptools.kicad.calc.heatsink --readme"
    assert "```text\n" + "\n".join(hs.motor_report()) + "\n```" in text


def test_a_stale_readme_heatsink_block_is_caught(monkeypatch):
    text = motor.README.read_text()
    hs.smallest.cache_clear()
    monkeypatch.setattr(hs, "MARGIN", 0.1)
    try:
        assert hs.readme_with_report(text) != text
    finally:
        hs.smallest.cache_clear()
    with pytest.raises(ValueError, match="markers"):
        hs.readme_with_report("no markers here")


def test_spreading_by_hand():
    """Lee, Song, Au & Moran's ψ_max worked by hand for the case's window (40 × 34 mm) on a
    100 × 100 × 6 mm base, k 200, h_eff 10 W/(m²·K): a = 20.806 mm, b = 56.419 mm, ε 0.36878,
    τ 0.10635, Bi 0.0028209, λ = π + 1/(√π ε) = 4.67148, φ = (tanh λτ + λ/Bi)/(1 + λ/Bi tanh λτ)
    = 2.17309, ψ = (ε τ + (1 − ε) φ)/√π = 0.79603, R = ψ / (√π k a) = 0.1079 K/W."""
    r = hs.spreading_resistance(0.040 * 0.034, 0.1 * 0.1, 6e-3, 200.0, 10.0)
    assert r == pytest.approx(0.1079, rel=1e-3)


def test_radiation_by_hand():
    """The envelope (tip face 0.1 × 0.1 m + two sides 0.1 × 0.05 m = 0.02 m²) at ε 0.8 and the
    fins' mean excess η ΔT, to surroundings at the ambient."""
    heat = hs.shed(SINK, 20.0)
    ta = 313.15
    want = 0.8 * 5.670374419e-8 * 0.02 * ((ta + heat.eta * 20.0) ** 4 - ta ** 4)
    assert heat.radiation == pytest.approx(want, rel=1e-9)
    assert 2.3 < heat.radiation < 2.5      # h_rad ≈ 4 ε σ T³ ≈ 6.1 W/(m²·K) × 0.02 m² × ~19.6 K
