"""The policies that ship with the package: a deploy config each in ``configs/``, named by the file's stem.

Apart from the config reader so that a client (the console's policy selector) can list them without importing
numpy, yaml or the model's runtime."""

from __future__ import annotations

from importlib import resources
from pathlib import Path


def builtin_configs() -> dict[str, Path]:
    """The policies that ship with the package, by name (the YAML file's stem)."""
    folder = resources.files("g1_mode_manager.policy") / "configs"
    return {Path(str(p)).stem: Path(str(p)) for p in folder.iterdir() if str(p).endswith(".yaml")}
