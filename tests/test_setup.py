"""scripts/setup: idempotent (a second run does no work) and a failing step says which step,
what failed and what to do."""
import os

from conftest import ROOT, run

SETUP = ["bash", str(ROOT / "scripts" / "setup")]


def test_second_run_does_no_work():
    first = run(SETUP)           # brings the machine up to date if anything changed
    assert first.returncode == 0, first.stdout
    p = run(SETUP)
    assert p.returncode == 0, p.stdout
    steps = [l for l in p.stdout.splitlines() if l.startswith("setup: ") and "(" in l]
    assert [l.split()[1] for l in steps] == ["apt", "rust", "python", "models3d", "fuzz", "mutants", "freerouting"]
    for line in steps:
        assert "up to date" in line or "skipped" in line, line
    assert p.stdout.rstrip().endswith("setup: done")


def test_failing_step_names_itself_and_what_to_do(tmp_path):
    # A PATH without rustup: the apt step is up to date, the rust step must fail clearly.
    path = ":".join(d for d in os.environ["PATH"].split(":") if not (os.path.isfile(os.path.join(d, "rustup"))))
    p = run(SETUP, env={"PATH": path})
    assert p.returncode != 0
    assert "setup: step 'rust' failed" in p.stdout
    assert "setup: what to do: rustup must be on PATH" in p.stdout
    assert "Traceback" not in p.stdout


def test_python_lock_pins_every_package_with_hashes():
    lock = (ROOT / "scripts" / "python" / "requirements.lock").read_text()
    pins = [l for l in lock.splitlines() if l and not l[0].isspace() and not l.startswith("#")]
    assert len(pins) > 20
    for pin in pins:
        assert "==" in pin, pin
    assert lock.count("--hash=sha256:") >= len(pins)
    wanted = (ROOT / "scripts" / "python" / "requirements.in").read_text().split()
    for req in (w for w in wanted if "==" in w):
        assert req in lock, f"{req} from requirements.in is not in requirements.lock: run scripts/python/lock"
