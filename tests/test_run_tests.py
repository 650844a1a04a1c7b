"""`make test` fails when any Rust, QEMU or pytest test fails, and when no test runs at all.

Each test points one stage of the test driver (scripts/run-tests) at a deliberately failing
suite in tests/fixtures and checks the exit status and the closing summary line.
"""
import shutil

from conftest import ROOT, run

DRIVER = [str(ROOT / "scripts" / "run-tests")]


def closing_line(out: str) -> str:
    return out.strip().splitlines()[-1]


def test_failing_rust_test_fails_the_run(tmp_path):
    crate = tmp_path / "crate"
    shutil.copytree(ROOT / "tests" / "fixtures" / "failing-crate", crate)
    # Outside the repository: name the toolchain (a fresh HOME has no rustup default).
    shutil.copy(ROOT / "rust-toolchain.toml", crate)
    p = run(DRIVER + ["--only", "rust", "--firmware-dir", str(crate)])
    assert p.returncode == 1, p.stdout
    assert "fails_on_purpose" in p.stdout
    assert closing_line(p.stdout) == "1 passed, 1 failed, 0 skipped"


def test_failing_qemu_test_fails_the_run():
    p = run(DRIVER + ["--only", "qemu", "--qemu-images", "deliberate-failure"])
    assert p.returncode == 1, p.stdout
    assert "runner::fails_on_purpose ... FAILED" in p.stdout
    assert closing_line(p.stdout) == "1 passed, 1 failed, 0 skipped"


def test_failing_pytest_test_fails_the_run():
    p = run(DRIVER + ["--only", "pytest", "--pytest-path",
                      str(ROOT / "tests" / "fixtures" / "failing_pytest")])
    assert p.returncode == 1, p.stdout
    assert closing_line(p.stdout) == "1 passed, 1 failed, 0 skipped"


def test_a_run_with_no_test_fails():
    p = run(DRIVER + ["--only", "pytest", "--pytest-path", str(ROOT / "tests" / "fixtures" / "no_tests")])
    assert p.returncode == 1, p.stdout
    assert "no test ran" in p.stdout
    assert closing_line(p.stdout) == "0 passed, 1 failed, 0 skipped"


def test_passing_stage_passes_and_counts():
    p = run(DRIVER + ["--only", "qemu", "--qemu-images", "rtcan"])
    assert p.returncode == 0, p.stdout
    passed = int(closing_line(p.stdout).split()[0])
    assert passed >= 10 and closing_line(p.stdout).endswith("0 failed, 0 skipped")


def test_unknown_stage_is_named():
    p = run(DRIVER + ["--only", "rust,typo"])
    assert p.returncode == 2
    assert "unknown stage typo" in p.stdout and "stages are: rust, lint, qemu, fuzz, pytest" in p.stdout
