"""Shared helpers for R2P's pytest suite (run by `make test`, stage `pytest`)."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))


def run(cmd: list[str], cwd: Path = ROOT, env: dict[str, str] | None = None,
        timeout: float = 900) -> subprocess.CompletedProcess[str]:
    """Runs a command, returning its exit status and combined output as text."""
    full_env = {**os.environ, **(env or {})}
    return subprocess.run(cmd, cwd=cwd, env=full_env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                          text=True, timeout=timeout)


def free_port() -> int:
    """A TCP port on 127.0.0.1 that was free a moment ago."""
    import socket
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class SocketcandProcess:
    """A program serving the socketcand protocol on 127.0.0.1 (r2p-canlink, r2p-emu), started
    with `args` plus `--socketcand 127.0.0.1:<free port>`, ready once it accepts connections.
    Tests stop it with `stop()`; their fixture always `kill()`s it."""

    def __init__(self, args: list[str], name: str):
        import socket
        import time
        self.port = free_port()
        self.proc = subprocess.Popen(
            [*args, "--socketcand", f"127.0.0.1:{self.port}"],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        deadline = time.monotonic() + 10
        while True:
            assert self.proc.poll() is None, self.proc.communicate(timeout=5)
            try:
                socket.create_connection(("127.0.0.1", self.port), timeout=1).close()
                break
            except OSError:
                assert time.monotonic() < deadline, f"{name} did not start listening"
                time.sleep(0.05)

    def bus(self):
        """A python-can client of the server."""
        import can
        return can.Bus(interface="socketcand", host="127.0.0.1", port=self.port, channel="vcan0")

    def stop(self) -> str:
        """SIGTERM; returns stderr after a clean exit."""
        self.proc.terminate()
        _, err = self.proc.communicate(timeout=10)
        assert self.proc.returncode == 0, err
        return err

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(timeout=10)
        for pipe in (self.proc.stdin, self.proc.stdout, self.proc.stderr):
            pipe.close()
