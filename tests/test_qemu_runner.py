"""The QEMU runner: core suites on an emulated Cortex-M3 report pass and fail to the shell,
deterministically."""
from conftest import ROOT, run

RUNNER = [str(ROOT / "scripts" / "qemu-test")]


def test_deliberate_failure_fails_with_its_name_and_reason():
    p = run(RUNNER + ["deliberate-failure"])
    assert p.returncode == 1, p.stdout
    assert "test runner::passes ... ok" in p.stdout
    assert "test runner::fails_on_purpose ... FAILED" in p.stdout
    assert "deliberate failure: an NRT frame is not HRT" in p.stdout
    assert "image deliberate-failure FAILED (qemu exit status 1)" in p.stdout


def test_core_suites_pass_and_match_the_host_suite():
    p = run(RUNNER + ["rtcan"])
    assert p.returncode == 0, p.stdout
    ran = [l for l in p.stdout.splitlines() if l.startswith("test rtcan::") and l.endswith(" ... ok")]
    # The same cases libtest runs on the host (suite! declares both): id and laxity at least.
    assert any("::id::" in l for l in ran) and any("::laxity::" in l for l in ran)
    assert f"test result: ok. {len(ran)} passed; 0 failed" in p.stdout


def test_runs_are_deterministic():
    a, b = run(RUNNER + ["rtcan"]), run(RUNNER + ["rtcan"])
    assert a.returncode == b.returncode == 0

    def image_output(out: str) -> list[str]:
        # What the Cortex-M3 printed (cargo's own lines carry wall-clock times).
        return out[out.index("running "):].splitlines()

    assert image_output(a.stdout) == image_output(b.stdout)


def test_default_run_runs_the_suites_and_skips_the_deliberate_failure():
    p = run(RUNNER)
    assert p.returncode == 0, p.stdout
    assert "deliberate-failure" not in p.stdout
    for suite in ("rtcan", "middleware", "management", "msgs"):
        assert f"({suite} on cortex-m3)" in p.stdout


def test_unknown_image_is_named_with_the_known_ones():
    p = run(RUNNER + ["nope"])
    assert p.returncode == 2
    assert "no image nope" in p.stdout and "rtcan" in p.stdout
