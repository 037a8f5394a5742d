"""The compiled scene's cache: a loaded model is the compiled one, and any change to what the compile reads compiles
again."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from g1_mode_manager.protocol import motors
from g1_sim.assets import assets_dir
from g1_sim.physics import model as g1_model
from g1_sim.physics.compiled_cache import CACHE_DIR, compiled_model

pytestmark = pytest.mark.sim


def _saved(m: mujoco.MjModel) -> bytes:
    buffer = np.empty(mujoco.mj_sizeModel(m), dtype=np.uint8)
    mujoco.mj_saveModel(m, None, buffer)
    return buffer.tobytes()


def test_a_cached_scene_is_the_compiled_one_and_a_changed_input_compiles_again(tmp_path: Path) -> None:
    real = assets_dir()
    assets = tmp_path / "assets"
    for path in (p for p in real.rglob("*") if p.is_file() and CACHE_DIR not in p.parts):
        (assets / path.relative_to(real)).parent.mkdir(parents=True, exist_ok=True)
        (assets / path.relative_to(real)).symlink_to(path)
    sources = (Path(g1_model.__file__), Path(motors.__file__))
    compiles: list[mujoco.MjModel] = []

    def compile_scene() -> mujoco.MjModel:
        compiles.append(g1_model._compile(assets))
        return compiles[-1]

    first = compiled_model(assets, sources, compile_scene)
    assert len(compiles) == 1 and len(list((assets / CACHE_DIR).glob("*.mjb"))) == 1
    loaded = compiled_model(assets, sources, compile_scene)
    assert len(compiles) == 1, "the second start compiled again"
    assert _saved(loaded) == _saved(first)

    (assets / "extra.xml").write_text("<mujoco/>")  # any asset file more, or changed, is another scene
    compiled_model(assets, sources, compile_scene)
    assert len(compiles) == 2

    for cached in (assets / CACHE_DIR).glob("*.mjb"):
        cached.write_bytes(b"torn")
    again = compiled_model(assets, sources, compile_scene)
    assert len(compiles) == 3 and _saved(again) == _saved(first)
