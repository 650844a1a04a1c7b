"""RTCAN under load (`make bench`, section 4): the sweep's output, the goal summary and the
plots. Behaviour only; the numbers themselves are reported by the bench, not asserted."""
from __future__ import annotations

import json

import pytest

from conftest import ROOT, run

FIRMWARE = ROOT / "firmware"
BIN = FIRMWARE / "target" / "debug" / "r2p-loadbench"
ARGS = ["--loads", "0.2,0.9", "--seconds", "0.3", "--seed", "5"]
WALL_CLOCK = {"wall_s", "events_per_s", "realtime_ratio"}


@pytest.fixture(scope="module")
def loadbench() -> None:
    p = run(["cargo", "build", "-q", "-p", "r2p-loadbench"], cwd=FIRMWARE, timeout=600)
    assert p.returncode == 0, p.stdout


def sweep(*args: str) -> tuple[list[dict], dict]:
    from r2ptools import bench
    p = run([str(BIN), *args], cwd=FIRMWARE)
    assert p.returncode == 0, p.stdout
    rows = bench.json_lines(p.stdout)
    return [r for r in rows if r["bench"] == "rtcan_load"], rows[-1]


def strip_clock(rows: list[dict]) -> list[dict]:
    return [{k: v for k, v in r.items() if k not in WALL_CLOCK} for r in rows]


def test_one_report_per_policy_and_load(loadbench):
    points, sim = sweep(*ARGS)
    assert [p["load"] for p in points] == [0.2, 0.9]
    for p in points:
        # The node runtime's default (merged windows), its other free-slot policy, the
        # frame-sized what-if (issue 22), the baseline.
        assert [r["policy"] for r in p["reports"]] == ["rtcan", "rtcan_oneshot", "rtcan_framed", "fixed"]
        assert abs(p["offered"] - p["load"]) <= 0.01 * p["load"]
        for r in p["reports"]:
            assert r["srt_messages"] > 0 and r["hrt_messages"] > 0
            assert 0 <= r["srt_miss_ratio"] <= 1 and 0 < r["utilisation"] < 1
    assert sim["bench"] == "rtcan_load_sim" and sim["runs"] == 8 and sim["events"] > 0


def test_same_seed_same_numbers_across_processes(loadbench):
    a, sa = sweep(*ARGS)
    b, sb = sweep(*ARGS)
    assert strip_clock(a) == strip_clock(b)
    assert sa["events"] == sb["events"]
    c, _ = sweep(*ARGS[:-1], "6")
    assert strip_clock(c) != strip_clock(a)


def test_plots_regenerate_byte_for_byte(loadbench, tmp_path):
    from r2ptools import bench
    points, _ = sweep(*ARGS)
    first = bench.plot_load(points, tmp_path / "a")
    second = bench.plot_load(json.loads(json.dumps(points)), tmp_path / "b")
    assert [p.name for p in first] == ["rtcan-load-srt-miss.png", "rtcan-load-latency.png",
                                       "rtcan-load-hrt-jitter.png", "rtcan-load-carried.png",
                                       "rtcan-load-layout.png"]
    for x, y in zip(first, second):
        assert x.read_bytes() == y.read_bytes(), x.name
        assert b"tEXt" not in x.read_bytes()  # no software/date stamp


def _point(load: float, rtcan_miss: float, fixed_miss: float, hrt_missed: int = 0) -> dict:
    def report(policy: str, miss: float) -> dict:
        return {"policy": policy, "srt_miss_ratio": miss, "hrt_missed": hrt_missed if policy == "rtcan" else 0}
    return {"load": load, "reports": [report("rtcan", rtcan_miss), report("fixed", fixed_miss)]}


def test_goal_summary_says_where_a_goal_fails():
    from r2ptools import bench
    goals = bench.load_goals([_point(0.5, 0.0, 0.001), _point(0.9, 0.002, 0.001, hrt_missed=3)])
    by_goal = {g: (ok, detail) for g, ok, detail in goals}
    name = bench.POLICIES["rtcan"][0]
    assert by_goal[f"{name}: 0 HRT misses at every load"] == (False, "3 missed")
    assert by_goal[f"{name}: SRT misses not above fixed priority at every load"] == (False, "above fixed at 90 %")
    assert by_goal[f"{name}: SRT misses ≤ 0.1 % at 90 % load"] == (False, "0.20 %")
    ok = {g: ok for g, ok, _ in bench.load_goals([_point(0.9, 0.0005, 0.001)])}
    assert all(ok.values())


def test_capacity_goals_say_where_they_fail():
    from r2ptools import bench

    def point(load, carried, p50, fixed_p50=100.0):
        return {"load": load, "reports": [
            {"policy": "rtcan_framed", "srt_miss_ratio": 0, "hrt_missed": 0, "utilisation": carried,
             "srt_p50_us": p50},
            {"policy": "fixed", "srt_miss_ratio": 0, "hrt_missed": 0, "utilisation": 0.94,
             "srt_p50_us": fixed_p50}]}

    name = bench.POLICIES["rtcan_framed"][0]
    goals = {g: (ok, d) for g, ok, d in bench.load_goals(
        [point(0.5, 0.5, 120), point(0.9, 0.9, 160), point(0.95, 0.919, 300)])}
    assert goals[f"{name}: carries ≥ 92 % of the bus at 95 % load"] == (False, "91.9 %")
    assert goals[f"{name}: median SRT latency ≤ 1.5× fixed priority's up to 90 %"] == (
        False, "at most 1.60×, above at 90 %")
    goals = {g: ok for g, ok, _ in bench.load_goals([point(0.9, 0.9, 150), point(0.95, 0.92, 300)])}
    assert all(goals.values()), goals


def test_seed_capacity_table_spans_the_seeds():
    from r2ptools import bench

    def point(load, carried, p50):
        return {"load": load, "reports": [
            {"policy": "rtcan", "utilisation": carried, "srt_p50_us": p50},
            {"policy": "fixed", "utilisation": 0.946, "srt_p50_us": 500.0}]}

    text = bench.seeds_capacity({1: [point(0.95, 0.823, 1500)], 2: [point(0.95, 0.80, 750)]})
    assert text.splitlines()[1].split() == ["0.95", "|", "80.0–82.3", "%", "94.6–94.6", "%", "|",
                                            "1.50–3.00"]


def test_seed_table_sums_misses_and_names_the_seeds_where_rtcan_misses_more():
    from r2ptools import bench

    def point(load, a, b, n=1000):
        def report(policy, missed):
            return {"policy": policy, "srt_missed": missed, "srt_messages": n}
        return {"load": load, "reports": [report("rtcan", a), report("fixed", b)]}

    text = bench.seeds_table({1: [point(0.9, 0, 5), point(0.95, 7, 3)],
                              2: [point(0.9, 2, 4), point(0.95, 1, 9)],
                              3: [point(0.9, 0, 0), point(0.95, 4, 2)]})
    lines = text.splitlines()
    assert lines[1] == " 0.90 |     3,000 |            2      9 | 0 of 3"
    assert lines[2] == " 0.95 |     3,000 |           12     14 | 2 of 3 (1, 3)"


def test_tables_show_ratios_against_fixed_priority(loadbench):
    from r2ptools import bench
    points, _ = sweep(*ARGS)
    text = bench.load_tables(points)
    assert "rtcan/fixed" in text and "reserved" in text
    assert len(text.splitlines()) == 2 + len(points) + 1 + 2 + len(points)


@pytest.mark.parametrize("args, message", [
    (["--loads", "1.5"], "outside (0, 1]"),
    (["--policies", "edf"], 'unknown policy "edf"'),
    (["--seconds", "0"], "must be in (0, 3600]"),
    (["--mix", "0.5"], "give two shares"),
    (["--frobnicate", "1"], "unknown option --frobnicate"),
    (["--blocks", "0"], "hrt_blocks = 0: use 1 … 4"),
    (["--blocks", "5"], "hrt_blocks = 5: use 1 … 4"),
    (["--blocks", "two"], "not a block count"),
    (["--laxity-drift", "64"], "give laxity code steps, 0 … 63"),
    (["--reactions", "0,29"], "give two positive whole µs, TRANSMIT,RELEASE"),
    (["--reactions", "27"], "give two positive whole µs, TRANSMIT,RELEASE"),
])
def test_bad_arguments_are_refused_with_the_reason(loadbench, args, message):
    p = run([str(BIN), *args], cwd=FIRMWARE)
    assert p.returncode != 0
    assert message in p.stdout


def test_what_ifs_for_the_median_goal_change_the_frame_sized_run_only_as_they_say(loadbench):
    """docs/rtcan.md, "What the median goal would take": each what-if is reported with the
    point, keeps every HRT frame at its reservation's start and inside it, and moves what it
    names: exact reservations are shorter than worst-case ones; faster reactions, a laxity
    drift and staged reloads (which the interrupt loads) shorten the frame-sized run's median
    SRT latency at 90 %."""
    base = ["--loads", "0.9", "--seconds", "1", "--policies", "rtcan_framed,fixed"]

    def framed(*args):
        (point,), _ = sweep(*base, *args)
        return point, next(r for r in point["reports"] if r["policy"] == "rtcan_framed")

    p0, f0 = framed()
    assert (p0["laxity_drift"], p0["reactions_us"], p0["hrt_exact"], p0["staged"], p0["hrt_follow"]) \
        == (0, [27, 29], False, False, False)
    assert f0["counters"]["staged"] == 0
    for args in (["--hrt-exact"], ["--reactions", "1,1"], ["--laxity-drift", "1"], ["--staged"]):
        p, f = framed(*args)
        assert f["hrt_missed"] == 0 and f["hrt_jitter_max_us"] == 0 and f["hrt_in_slot"] == 1, args
        assert f["srt_p50_us"] < f0["srt_p50_us"], args
    p, f = framed("--staged")
    assert p["staged"] is True and f["counters"]["staged"] > 0
    p, _ = framed("--hrt-exact")
    assert p["hrt_exact"] is True
    # The same streams in the same slots (the sync's, slot 0, unchanged), each no longer.
    lengths = lambda q: {s[0]: s[2] for s in q["framed_slots"]}  # noqa: E731
    exact, worst = lengths(p), lengths(p0)
    assert exact.keys() == worst.keys() and exact[0] == worst[0]
    assert all(exact[k] <= worst[k] for k in worst) and sum(exact.values()) < sum(worst.values())
    # HRT frames that follow each other: early (a start jitter), each still ending inside its
    # reservation, and the median shorter.
    p, f = framed("--hrt-follow")
    assert p["hrt_follow"] is True and f["hrt_missed"] == 0 and f["hrt_ended_in_slot"] == 1
    assert f["hrt_jitter_max_us"] > 0 and f["hrt_in_slot"] < 1
    assert f["srt_p50_us"] < f0["srt_p50_us"]


def test_whatif_table_gives_the_ratio_span_the_seeds_within_and_whether_the_other_goals_held():
    from r2ptools import bench

    def point(load, framed, fixed, carried=0.93, missed=(0, 0), jitter=0):
        f = {"policy": "rtcan_framed", "srt_p50_us": framed, "hrt_missed": 0, "hrt_in_slot": 1,
             "hrt_jitter_max_us": jitter, "srt_missed": missed[0], "utilisation": carried}
        x = {"policy": "fixed", "srt_p50_us": fixed, "srt_missed": missed[1]}
        return {"load": load, "reports": [f, x]}

    runs = {"as now": {1: [point(0.8, 150, 100), point(0.95, 200, 100, carried=0.921)],
                       2: [point(0.8, 140, 100), point(0.95, 210, 100)]},
            "--staged": {1: [point(0.8, 130, 100), point(0.95, 160, 100, carried=0.919)],
                         2: [point(0.8, 160, 100, missed=(3, 2)), point(0.95, 150, 100)]},
            "--hrt-exact": {1: [point(0.8, 120, 100), point(0.95, 140, 100, jitter=2)],
                            2: [point(0.8, 120, 100), point(0.95, 140, 100)]}}
    now, staged, exact = bench.whatifs_table(runs).splitlines()[1:]
    assert "1.40–1.50  2/2" in now and "2.00–2.10  0/2" in now
    assert now.endswith("92.10–93.00 % | kept")
    assert "1.30–1.60  1/2" in staged and "1.50–1.60  1/2" in staged  # 1.5 is within
    assert staged.endswith("91.90–93.00 % | NOT kept (carried < 92 %)")
    assert exact.endswith("| NOT kept (HRT starts up to 2 µs off)")
