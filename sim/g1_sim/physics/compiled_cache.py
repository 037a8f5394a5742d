"""The compiled G1 scene, kept beside the assets: compiling the scene's meshes costs every sim start most of a second
of CPU, loading MuJoCo's binary of the same model a tenth of that, and a test run starts dozens of sims.

The binary is MuJoCo's own save of the compiled model, so a loaded model is the compiled one, bit for bit. Its key
covers everything the compile reads: MuJoCo's version, the sources that edit the spec before compiling (``model.py``
and the motor table), and every asset file's name, size and modification time. A cache that cannot be written (a
read-only install) or read (a torn file) is passed over and the scene compiled.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import tempfile
from collections.abc import Callable, Iterable
from pathlib import Path

import mujoco

CACHE_DIR = ".compiled"


def cache_key(assets_root: Path, sources: Iterable[Path]) -> str:
    h = hashlib.sha256(mujoco.__version__.encode())
    for source in sources:
        h.update(source.read_bytes())
    for path in sorted(p for p in assets_root.rglob("*") if p.is_file() and CACHE_DIR not in p.parts):
        st = path.stat()
        h.update(f"{path.relative_to(assets_root)}\0{st.st_size}\0{st.st_mtime_ns}\n".encode())
    return h.hexdigest()[:24]


def compiled_model(assets_root: Path, sources: Iterable[Path], compile_scene: Callable[[], mujoco.MjModel]
                   ) -> mujoco.MjModel:
    """The model ``compile_scene()`` returns, loaded from the cache when this very scene was compiled before."""
    path = assets_root / CACHE_DIR / f"g1-{cache_key(assets_root, sources)}.mjb"
    if path.is_file():
        try:
            return mujoco.MjModel.from_binary_path(str(path))
        except Exception:  # a torn or foreign file: compile instead, and replace it
            pass
    model = compile_scene()
    tmp = None
    try:
        path.parent.mkdir(exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".part")
        os.close(fd)
        mujoco.mj_saveModel(model, tmp, None)
        os.chmod(tmp, 0o644)  # mkstemp's 0600 would keep it from sims of other users of the same install
        os.replace(tmp, path)  # whole or not at all, whichever of several sims starting together writes it
    except OSError:
        if tmp is not None:  # a full disk must not keep a part of a large file
            with contextlib.suppress(OSError):
                os.unlink(tmp)
    return model
