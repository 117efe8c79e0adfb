"""The layers of docs/architecture.md hold: import-linter checks the contracts in pyproject.toml.

The second test reverses the layer order in a copy of the contract and expects it broken, so a checker that
silently analyses nothing (a wrong root package, an empty graph) cannot pass.
"""

from __future__ import annotations

import subprocess
import sys
import tomllib
from pathlib import Path

REPOSITORY = Path(__file__).resolve().parents[1]


def _lint_imports(config: Path) -> subprocess.CompletedProcess[str]:
    command = "from importlinter.cli import lint_imports_command; lint_imports_command()"
    return subprocess.run(
        [sys.executable, "-c", command, "--config", str(config), "--no-cache", "--no-logo"],
        cwd=REPOSITORY,
        capture_output=True,
        text=True,
        timeout=300,
    )


def test_every_contract_is_kept() -> None:
    result = _lint_imports(REPOSITORY / "pyproject.toml")
    assert result.returncode == 0, result.stdout[-4000:] + result.stderr[-2000:]
    assert "0 broken" in result.stdout


def test_a_reversed_layer_order_is_reported_broken(tmp_path: Path) -> None:
    settings = tomllib.loads((REPOSITORY / "pyproject.toml").read_text())["tool"]["importlinter"]
    layers = next(c for c in settings["contracts"] if c["type"] == "layers")["layers"]
    reversed_layers = ", ".join(f'"{layer}"' for layer in reversed(layers))
    roots = ", ".join(f'"{root}"' for root in settings["root_packages"])
    config = tmp_path / "reversed.toml"
    config.write_text(
        "[tool.importlinter]\n"
        f"root_packages = [{roots}]\n"
        "[[tool.importlinter.contracts]]\n"
        'name = "reversed"\ntype = "layers"\n'
        f"layers = [{reversed_layers}]\n"
    )
    result = _lint_imports(config)
    assert result.returncode == 1, result.stdout[-4000:]
    assert "BROKEN" in result.stdout
    assert "ornitail.app" in result.stdout  # the app imports every area below it
