"""Where the simulator's model and policy files live (installed by ``make setup``, never fetched at run time)."""

from __future__ import annotations

import os
import sys
from pathlib import Path

#: Overrides the default location, e.g. for a checkout whose venv lives elsewhere.
ASSETS_ENV = "G1_SIM_ASSETS"
SCENE_XML = Path("unitree_g1") / "scene.xml"
POLICY_ONNX = Path("policy") / "ppo_g1_29dof.onnx"


class AssetsMissingError(FileNotFoundError):
    """The simulation assets are not installed; ``make setup`` installs them."""


def default_assets_dir() -> Path:
    """``$G1_SIM_ASSETS`` if set, else ``<sys.prefix>/share/g1_mode_manager/sim_assets``."""
    env = os.environ.get(ASSETS_ENV)
    if env:
        return Path(env)
    return Path(sys.prefix) / "share" / "g1_mode_manager" / "sim_assets"


def assets_dir(path: str | os.PathLike[str] | None = None) -> Path:
    """The assets folder, checked to hold the G1 scene and the locomotion policy."""
    root = Path(path) if path is not None else default_assets_dir()
    missing = [str(root / p) for p in (SCENE_XML, POLICY_ONNX) if not (root / p).is_file()]
    if missing:
        raise AssetsMissingError(
            f"G1 simulation assets not found ({', '.join(missing)}); run `make setup` "
            f"or point ${ASSETS_ENV} at a folder holding {SCENE_XML} and {POLICY_ONNX}"
        )
    return root


def scene_xml(root: Path) -> Path:
    return root / SCENE_XML


def policy_onnx(root: Path) -> Path:
    return root / POLICY_ONNX
