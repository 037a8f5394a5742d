"""A policy's action scale comes from what its model was trained with: the model's metadata, then the training config
it embeds, then its deploy config; the rule that decided is said at load, a tracking model no rule covers is refused,
and a deploy config that contradicts the model is refused unless it says it overrides it."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from g1_mode_manager.core.controller.interface import ControllerError
from g1_mode_manager.policy.action_scale import EFFORT_OVER_KP, FLAT, ScaleRequest, resolve_action_scale
from g1_mode_manager.policy.loader import load_policy
from g1_mode_manager.protocol.motors import EFFORT_LIMIT_NM, NUM_JOINTS

POLICY_DIR = Path(sys.prefix) / "share/g1_mode_manager/sim_assets/policy"
KP = np.full(NUM_JOINTS, 40.0)
TRAINED = {"experiment_config": json.dumps({"robot": {"control": {
    "action_scale": 0.25, "action_scales_by_effort_limit_over_p_gain": True}}})}
PER_JOINT = 0.25 * np.array(EFFORT_LIMIT_NM) / KP


def test_the_shipped_dances_get_the_scale_each_was_trained_with_and_say_which_rule_gave_it() -> None:
    ppo = load_policy("dance_ppo", POLICY_DIR)
    assert "embedded training config" in ppo.action_scale_rule and "per joint" in ppo.action_scale_rule
    assert ppo.action_scale.min() == pytest.approx(0.0745, abs=1e-4) and ppo.action_scale.max() > 0.5
    fastsac = load_policy("dance_fastsac", POLICY_DIR)
    assert np.all(fastsac.action_scale == 1.0)
    assert fastsac.action_scale_rule.startswith("its deploy config (holosoma's first release")
    walker = load_policy("loco_ppo", POLICY_DIR)
    assert np.all(walker.action_scale == 0.25) and "flat 0.25" in walker.action_scale_rule


def test_the_models_own_metadata_comes_first_as_a_number_a_list_or_comma_separated() -> None:
    for raw in ("1.0", "[1.0]", "1.0"):
        scale = resolve_action_scale("p", "motion_tracking", ScaleRequest(), {"action_scale": raw}, KP)
        assert np.all(scale.values == 1.0) and scale.rule == "the model's action_scale metadata (flat 1)"
    per_joint = ",".join(["0.5"] * NUM_JOINTS)
    scale = resolve_action_scale("p", "motion_tracking", ScaleRequest(), {"action_scale": per_joint, **TRAINED}, KP)
    assert np.all(scale.values == 0.5)  # the metadata's own word beats the embedded config's
    with pytest.raises(ControllerError, match="not numbers"):
        resolve_action_scale("p", "motion_tracking", ScaleRequest(), {"action_scale": "fast"}, KP)
    with pytest.raises(ControllerError, match="1 or 29 finite action scales > 0"):
        resolve_action_scale("p", "motion_tracking", ScaleRequest(), {"action_scale": "[0.5, 0.5]"}, KP)


def test_the_embedded_training_config_gives_per_joint_effort_over_kp_or_flat() -> None:
    scale = resolve_action_scale("p", "motion_tracking", ScaleRequest(), TRAINED, KP)
    assert np.allclose(scale.values, PER_JOINT)
    flat = {"experiment_config": json.dumps({"robot": {"control": {"action_scale": 0.5}}})}
    assert np.all(resolve_action_scale("p", "motion_tracking", ScaleRequest(), flat, KP).values == 0.5)
    # the model's trained stiffness (its kp metadata) divides, not the deploy config's
    trained_kp = {**TRAINED, "kp": json.dumps([80.0] * NUM_JOINTS)}
    assert np.allclose(resolve_action_scale("p", "motion_tracking", ScaleRequest(), trained_kp, KP).values,
                       PER_JOINT / 2)


def test_a_tracking_model_that_says_nothing_needs_its_deploy_config_to_say_the_rule() -> None:
    with pytest.raises(ControllerError, match="action_scale_by"):
        resolve_action_scale("p", "motion_tracking", ScaleRequest(0.25), {}, KP)
    with pytest.raises(ControllerError, match="no action scale"):
        resolve_action_scale("p", "motion_tracking", ScaleRequest(), {}, KP)
    per_joint = resolve_action_scale("p", "motion_tracking", ScaleRequest(0.25, EFFORT_OVER_KP, "a paper"), {}, KP)
    assert np.allclose(per_joint.values, PER_JOINT) and per_joint.rule.startswith("its deploy config (a paper)")
    # a walker's config may leave the rule out: holosoma scales its walkers flat
    assert np.all(resolve_action_scale("p", "locomotion", ScaleRequest(0.25), {}, KP).values == 0.25)


def test_a_deploy_config_that_contradicts_the_model_is_refused_unless_it_overrides_it() -> None:
    with pytest.raises(ControllerError, match="action_scale_override"):
        resolve_action_scale("p", "motion_tracking", ScaleRequest(1.0, FLAT), TRAINED, KP)
    agrees = resolve_action_scale("p", "motion_tracking", ScaleRequest(0.25, EFFORT_OVER_KP), TRAINED, KP)
    assert np.allclose(agrees.values, PER_JOINT) and agrees.rule.endswith("its deploy config agrees")
    overridden = resolve_action_scale("p", "motion_tracking", ScaleRequest(1.0, FLAT, override=True), TRAINED, KP)
    assert np.all(overridden.values == 1.0) and "overriding the model's embedded training config" in overridden.rule


def test_a_bad_scale_field_in_the_yaml_is_refused_at_load_naming_it(tmp_path: Path) -> None:
    import yaml

    from g1_mode_manager.policy.deploy_config import read_config

    _, raw = read_config("dance_fastsac")
    raw["model"] = str(POLICY_DIR / raw["model"])
    for key, bad, why in (("action_scale_by", "per_joint", "action_scale_by 'per_joint'"),
                          ("action_scale_override", "yes", "action_scale_override must be true or false"),
                          ("action_scale", -1.0, "action_scale must be > 0")):
        path = tmp_path / f"{key}.yaml"
        path.write_text(yaml.safe_dump({**raw, key: bad}))
        with pytest.raises(ControllerError, match=why):
            load_policy(str(path), POLICY_DIR)
