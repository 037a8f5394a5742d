"""A policy's action scale (targets = default pose + scale x action), taken from what the model was trained with.

The same export format carries models trained with different rules: holosoma's PPO dance was trained with 0.25 x
each joint's effort limit / its stiffness, its FastSAC dance with a flat 1.0, and neither rule can be told from the
network itself. Played with the other's rule a dance falls within seconds (docs/policies.md). So the scale is read
from the model first and the deploy config is asked only where the model is silent; the rule that decided is said
at load. In order:

1. the model's ``action_scale`` metadata (a number, one per joint, or comma-separated numbers: holosoma's reader);
2. the training config the model embeds (``experiment_config``: ``robot.control.action_scale``, per joint as effort
   limit / stiffness when ``action_scales_by_effort_limit_over_p_gain``);
3. the deploy config: ``action_scale`` with ``action_scale_by`` (``flat``, or ``effort_over_kp``), and
   ``action_scale_source`` saying where the figure comes from. A locomotion config may leave ``action_scale_by``
   out (holosoma scales its walkers flat); a tracking policy's config must say it, or the policy is refused.

A deploy config that contradicts the model is refused, unless it says ``action_scale_override: true``.
"""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Final

import numpy as np

from g1_mode_manager.core.controller.interface import ControllerError
from g1_mode_manager.protocol.motors import EFFORT_LIMIT_NM, JOINT_NAMES, NUM_JOINTS

FLAT: Final = "flat"
EFFORT_OVER_KP: Final = "effort_over_kp"
SCALE_BY: Final = (FLAT, EFFORT_OVER_KP)


@dataclass(frozen=True)
class ScaleRequest:
    """What a deploy config says of the scale (all None: nothing)."""

    value: float | None = None
    by: str | None = None
    source: str = ""
    override: bool = False


@dataclass(frozen=True)
class ActionScale:
    values: np.ndarray  # (29,), motor order
    rule: str  # which rule gave it, for the load's answer, the log and ~/policy/status


def describe(values: np.ndarray) -> str:
    low, high = float(values.min()), float(values.max())
    return f"flat {low:g}" if np.isclose(low, high) else f"per joint {low:.3g}-{high:.3g}"


def resolve_action_scale(policy: str, kind: str, request: ScaleRequest, metadata: Mapping[str, str],
                         kp: np.ndarray, effort: Mapping[str, float] | None = None) -> ActionScale:
    """The scale of ``policy`` by the rules above. ``kp``: the deploy config's gains (the model's ``kp`` metadata,
    its training stiffness, wins); ``effort``: the joints' effort limits by name (the model's URDF), else the G1's."""
    limits = np.array([(effort or {}).get(n, EFFORT_LIMIT_NM[i]) for i, n in enumerate(JOINT_NAMES)])
    trained_kp = _trained_kp(policy, metadata, kp)
    from_model = _from_metadata(policy, metadata) or _from_training_config(policy, metadata, limits, trained_kp)
    from_config = None
    if request.value is not None:
        by = request.by if request.by is not None else (FLAT if kind == "locomotion" else None)
        if by is None and from_model is None:
            raise ControllerError(
                f"policy {policy}: the model does not say how its actions are scaled (no action_scale metadata, no "
                f"embedded training config), so its deploy config must: action_scale_by ({' or '.join(SCALE_BY)}) "
                "beside action_scale, with action_scale_source saying where they come from; models of one format are "
                "trained with either, and the wrong one makes a tracking policy fall")
        if by is not None:
            from_config = _by_rule(policy, request.value, by, limits, trained_kp,
                                   "its deploy config" + (f" ({request.source})" if request.source else ""))
    if from_model is None and from_config is None:
        raise ControllerError(f"policy {policy}: no action scale: the model carries none and its deploy config gives "
                              "no action_scale")
    if from_model is None:
        assert from_config is not None
        return from_config
    if from_config is None or np.allclose(from_config.values, from_model.values, rtol=1e-6, atol=0.0):
        agrees = "" if from_config is None else "; its deploy config agrees"
        return ActionScale(from_model.values, from_model.rule + agrees)
    if request.override:
        return ActionScale(from_config.values, f"{from_config.rule}, overriding {from_model.rule} "
                                               "(action_scale_override)")
    raise ControllerError(f"policy {policy}: {from_config.rule} says action scale {describe(from_config.values)}, "
                          f"but {from_model.rule} gives {describe(from_model.values)}: leave action_scale out of the "
                          "deploy config, or set action_scale_override: true if the model's is wrong")


def urdf_effort_limits(policy: str, metadata: Mapping[str, str]) -> dict[str, float] | None:
    """The joints' effort limits (N m) in the URDF the model carries (holosoma's ``robot_urdf``); None: it has none."""
    if "robot_urdf" not in metadata:
        return None
    try:
        root = ET.fromstring(str(json.loads(metadata["robot_urdf"])))
        return {str(j.get("name")): float(limit.get("effort", "nan")) for j in root.iter("joint")
                if (limit := j.find("limit")) is not None and limit.get("effort") is not None}
    except (ValueError, ET.ParseError) as exc:
        raise ControllerError(f"policy {policy}: the model's robot_urdf cannot be read: {exc}") from None


def _by_rule(policy: str, value: float, by: str, limits: np.ndarray, kp: np.ndarray, who: str) -> ActionScale:
    if by == FLAT:
        return _checked(policy, np.full(NUM_JOINTS, value), f"{who}: flat {value:g}")
    if by == EFFORT_OVER_KP:
        with np.errstate(divide="ignore", invalid="ignore"):
            values = value * limits / kp
        return _checked(policy, values, f"{who}: {value:g} x effort limit / kp per joint ({describe(values)})")
    raise ControllerError(f"policy {policy}: action_scale_by {by!r} is not one of {', '.join(SCALE_BY)}")


def _from_metadata(policy: str, metadata: Mapping[str, str]) -> ActionScale | None:
    raw = metadata.get("action_scale")
    if raw is None:
        return None
    try:
        parsed: Any = json.loads(raw)
    except ValueError:
        parsed = raw
    try:
        values = np.asarray([float(v) for v in parsed.split(",") if v.strip()] if isinstance(parsed, str) else parsed,
                            dtype=float).reshape(-1)
    except (ValueError, TypeError):
        raise ControllerError(f"policy {policy}: the model's action_scale metadata {raw!r} is not numbers") from None
    if values.size == 1:
        values = np.full(NUM_JOINTS, values[0])
    checked = _checked(policy, values, "the model's action_scale metadata")
    return ActionScale(checked.values, f"the model's action_scale metadata ({describe(checked.values)})")


def _from_training_config(policy: str, metadata: Mapping[str, str], limits: np.ndarray,
                          kp: np.ndarray) -> ActionScale | None:
    raw = metadata.get("experiment_config")
    if raw is None:
        return None
    try:
        control = json.loads(raw)["robot"]["control"]
        value = float(control["action_scale"])
        per_joint = bool(control.get("action_scales_by_effort_limit_over_p_gain", False))
    except (ValueError, KeyError, TypeError):
        return None  # a training config that does not say it: the rule below decides
    return _by_rule(policy, value, EFFORT_OVER_KP if per_joint else FLAT, limits, kp,
                    "the model's embedded training config (robot.control.action_scale"
                    + (", action_scales_by_effort_limit_over_p_gain)" if per_joint else ")"))


def _trained_kp(policy: str, metadata: Mapping[str, str], kp: np.ndarray) -> np.ndarray:
    if "kp" not in metadata:
        return np.asarray(kp, dtype=float)
    try:
        values = np.asarray(json.loads(metadata["kp"]), dtype=float).reshape(-1)
    except (ValueError, TypeError):
        raise ControllerError(f"policy {policy}: the model's kp metadata is not {NUM_JOINTS} numbers") from None
    if values.shape != (NUM_JOINTS,):
        raise ControllerError(f"policy {policy}: the model's kp metadata has {values.size} values, not {NUM_JOINTS}")
    return values


def _checked(policy: str, values: np.ndarray, who: str) -> ActionScale:
    if values.shape != (NUM_JOINTS,) or not np.all(np.isfinite(values)) or np.any(values <= 0.0):
        raise ControllerError(f"policy {policy}: {who} must give 1 or {NUM_JOINTS} finite action scales > 0, got "
                              f"{np.asarray(values).tolist()}")
    return ActionScale(values, who)
