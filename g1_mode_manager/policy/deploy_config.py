"""A policy's deploy config: what turns the robot's state into the model's input and its output into targets.

Read from a small YAML file (``configs/<name>.yaml``, or a user's own file) and from the model's ONNX metadata
where the model carries it (holosoma exports ``kp``, ``kd``, ``dof_names`` and ``command_ranges``); the YAML wins
where both say something, so a model without metadata is deployed by its YAML alone. Every field is checked
here, with an error that names it: a policy that cannot be described is refused at load, never at the first tick.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from g1_mode_manager.core.controller.interface import ControllerError
from g1_mode_manager.core.joint_commands import MAX_KD, MAX_KP
from g1_mode_manager.policy.action_scale import SCALE_BY, ScaleRequest
from g1_mode_manager.policy.builtin import builtin_configs
from g1_mode_manager.protocol.motors import JOINT_NAMES, JOINT_RANGE_RAD, NUM_JOINTS

KINDS = ("locomotion", "motion_tracking")
READY_POSES = ("default", "first_frame")


@dataclass(frozen=True)
class ObservationSpec:
    input: str
    terms: tuple[str, ...]
    scales: dict[str, float]


@dataclass(frozen=True)
class DeployConfig:
    name: str
    kind: str
    model: Path
    rate_hz: float
    #: what the YAML says of the action scale; the model's own word comes first (policy/action_scale.py)
    action_scale: ScaleRequest
    action_clip: float
    default_pose: np.ndarray  # (29,) rad, motor order
    kp: np.ndarray  # (29,) N m/rad
    kd: np.ndarray  # (29,) N m s/rad
    observation: ObservationSpec
    gait_period_s: float = 1.0
    #: the gains that hold the pose a tracking policy starts from while the engage blends there (holosoma's
    #: stiff_startup_kp / kd); the policy's own where the config gives none
    ready_kp: np.ndarray | None = None
    ready_kd: np.ndarray | None = None
    #: what a tracking policy's engage blends to: "default" (its default pose, as holosoma holds it before the
    #: policy starts) or "first_frame" (the clip's first frame)
    ready_pose: str = "default"
    #: a tracking policy runs this long at its clip's first time step before the clip plays, s (holosoma's policy
    #: runs at step 0 until the operator starts the motion)
    start_hold_s: float = 0.0
    command_ranges: tuple[tuple[float, float], ...] = ((-1.0, 1.0), (-1.0, 1.0), (-1.0, 1.0))  # vx, vy, wz


def config_path(policy: str) -> Path:
    """``policy`` is a built-in name or a path to a YAML file."""
    builtin = builtin_configs()
    if policy in builtin:
        return builtin[policy]
    path = Path(policy).expanduser()
    if path.suffix in (".yaml", ".yml") and path.is_file():
        return path
    raise ControllerError(f"no policy {policy!r}: give one of {', '.join(sorted(builtin))} or a deploy config's "
                          "path (.yaml)")


def read_config(policy: str) -> tuple[str, dict[str, Any]]:
    """(name, the YAML's fields) of ``policy``, a built-in name or a deploy config's path."""
    path = config_path(policy)
    try:
        raw = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise ControllerError(f"deploy config {path}: {exc}") from exc
    if not isinstance(raw, dict):
        raise ControllerError(f"deploy config {path}: not a mapping")
    return path.stem, raw


def resolve_model(name: str, raw: dict[str, Any], model_dir: Path) -> Path:
    """The ONNX file its ``model`` field names, relative to ``model_dir`` (an absolute path as it is)."""
    model = raw.get("model")
    if not isinstance(model, str) or not model:
        raise ControllerError(f"policy {name}: 'model' must name the ONNX file")
    found = Path(model).expanduser() if Path(model).expanduser().is_absolute() else model_dir / model
    if not found.is_file():
        raise ControllerError(f"policy {name}: model {found} not found (policy_dir: {model_dir})")
    return found


def parse_deploy_config(raw: dict[str, Any], *, name: str, model: Path, metadata: dict[str, str]) -> DeployConfig:
    def field(key: str, default: Any = None) -> Any:
        if key in raw:
            return raw[key]
        if key in metadata:
            return json.loads(metadata[key])
        if default is None:
            raise ControllerError(f"policy {name}: '{key}' is missing (neither in its YAML nor in the model)")
        return default

    kind = field("kind")
    if kind not in KINDS:
        raise ControllerError(f"policy {name}: kind {kind!r} is not one of {', '.join(KINDS)}")
    names = tuple(field("dof_names", list(JOINT_NAMES)))
    if names != JOINT_NAMES:
        raise ControllerError(f"policy {name}: its joints are not the G1's 29 in motor order: {list(names)}")
    obs = field("observation")
    if not isinstance(obs, dict) or not obs.get("terms") or not obs.get("input"):
        raise ControllerError(f"policy {name}: 'observation' needs 'input' and 'terms'")
    rate_hz = _positive(name, "rate_hz", field("rate_hz"))
    pose = _joint_vector(name, "default_pose", field("default_pose"))
    for i, (q, (low, high)) in enumerate(zip(pose, JOINT_RANGE_RAD, strict=True)):
        if not low <= q <= high:
            raise ControllerError(f"policy {name}: default_pose of {JOINT_NAMES[i]} ({q}) is outside its range")
    kp, kd = _joint_vector(name, "kp", field("kp")), _joint_vector(name, "kd", field("kd"))
    ready_kp = _joint_vector(name, "ready_kp", raw["ready_kp"]) if "ready_kp" in raw else kp
    ready_kd = _joint_vector(name, "ready_kd", raw["ready_kd"]) if "ready_kd" in raw else kd
    for gains, key, high in ((kp, "kp", MAX_KP), (kd, "kd", MAX_KD), (ready_kp, "ready_kp", MAX_KP),
                             (ready_kd, "ready_kd", MAX_KD)):
        if np.any(gains < 0.0) or np.any(gains > high):
            raise ControllerError(f"policy {name}: {key} must lie within [0, {high}] for every joint")
    return DeployConfig(
        name=name, kind=kind, model=model, rate_hz=rate_hz,
        action_scale=_scale_request(name, raw),
        action_clip=_positive(name, "action_clip", field("action_clip", 100.0)),
        default_pose=pose, kp=kp, kd=kd, ready_kp=ready_kp, ready_kd=ready_kd,
        observation=ObservationSpec(str(obs["input"]), tuple(map(str, obs["terms"])),
                                    {str(k): float(v) for k, v in (obs.get("scales") or {}).items()}),
        gait_period_s=_positive(name, "gait_period_s", field("gait_period_s", 1.0)),
        command_ranges=_command_ranges(name, field("command_ranges", "none")),
        ready_pose=_ready_pose(name, field("ready_pose", "default")),
        start_hold_s=_non_negative(name, "start_hold_s", field("start_hold_s", 0.0)),
    )


def _scale_request(name: str, raw: dict[str, Any]) -> ScaleRequest:
    """The YAML's action scale fields, checked (their meaning: policy/action_scale.py)."""
    value = _positive(name, "action_scale", raw["action_scale"]) if "action_scale" in raw else None
    by = raw.get("action_scale_by")
    if by is not None and by not in SCALE_BY:
        raise ControllerError(f"policy {name}: action_scale_by {by!r} is not one of {', '.join(SCALE_BY)}")
    if by is not None and value is None:
        raise ControllerError(f"policy {name}: action_scale_by is given without action_scale")
    override = raw.get("action_scale_override", False)
    if not isinstance(override, bool):
        raise ControllerError(f"policy {name}: action_scale_override must be true or false, got {override!r}")
    source = raw.get("action_scale_source", "")
    if not isinstance(source, str):
        raise ControllerError(f"policy {name}: action_scale_source must be text, got {source!r}")
    return ScaleRequest(value, by, source.strip(), override)


def _ready_pose(name: str, value: Any) -> str:
    if value not in READY_POSES:
        raise ControllerError(f"policy {name}: ready_pose {value!r} is not one of {', '.join(READY_POSES)}")
    return str(value)


def _non_negative(name: str, key: str, value: Any) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ControllerError(f"policy {name}: {key} must be a number, got {value!r}") from None
    if not (np.isfinite(number) and number >= 0.0):
        raise ControllerError(f"policy {name}: {key} must be finite and >= 0, got {value!r}")
    return number


def _positive(name: str, key: str, value: Any) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ControllerError(f"policy {name}: {key} must be a number, got {value!r}") from None
    if not np.isfinite(x) or x <= 0.0:
        raise ControllerError(f"policy {name}: {key} must be > 0, got {value!r}")
    return x


def _joint_vector(name: str, key: str, value: Any) -> np.ndarray:
    try:
        v = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ControllerError(f"policy {name}: {key} must be {NUM_JOINTS} numbers") from None
    if v.shape != (NUM_JOINTS,) or not np.all(np.isfinite(v)):
        raise ControllerError(f"policy {name}: {key} must be {NUM_JOINTS} finite numbers, got shape {v.shape}")
    return v


def _command_ranges(name: str, value: Any) -> tuple[tuple[float, float], ...]:
    """holosoma's ``command_ranges`` (lin_vel_x, lin_vel_y, ang_vel_yaw); none for a policy without a command."""
    if value in (None, "none"):
        return ((0.0, 0.0),) * 3
    try:
        return tuple((float(value[k][0]), float(value[k][1])) for k in ("lin_vel_x", "lin_vel_y", "ang_vel_yaw"))
    except (KeyError, TypeError, IndexError, ValueError):
        raise ControllerError(f"policy {name}: command_ranges needs lin_vel_x, lin_vel_y and ang_vel_yaw") from None
