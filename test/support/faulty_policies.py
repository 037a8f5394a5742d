"""Policies made faulty on purpose, built from holosoma's locomotion model with onnx's graph helpers: the real
walker, whose actions turn non-finite, or whose inference turns slow, once the teleop drives faster than a set
speed. Standing (and the load's probe inference at 0.3 m/s) they are the walker itself, so they load, shadow and
engage like it and fail only mid-run."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
import onnx
import onnxruntime as ort
import yaml
from onnx import TensorProto, helper

from g1_mode_manager.policy.deploy_config import builtin_configs

LOCO = Path(sys.prefix, "share", "g1_mode_manager", "sim_assets", "policy", "ppo_g1_29dof.onnx")
#: actor_obs' forward command (terms in sorted order: actions 29, base_ang_vel 3, command_ang_vel 1, then vx).
VX_AT = 33
#: Above this forward command the faulty policies fail, m/s (the load's probe drives at 0.3).
FAIL_ABOVE_MPS = 0.45


def _vx(graph: onnx.GraphProto) -> str:
    graph.initializer.extend([helper.make_tensor("vx_start", TensorProto.INT64, [1], [VX_AT]),
                              helper.make_tensor("vx_end", TensorProto.INT64, [1], [VX_AT + 1]),
                              helper.make_tensor("vx_axis", TensorProto.INT64, [1], [1]),
                              helper.make_tensor("fail_above", TensorProto.FLOAT, [], [FAIL_ABOVE_MPS]),
                              helper.make_tensor("zero", TensorProto.FLOAT, [], [0.0])])
    graph.node.append(helper.make_node("Slice", ["actor_obs", "vx_start", "vx_end", "vx_axis"], ["vx"]))
    return "vx"


def _rewire(model: onnx.ModelProto, extra: str) -> None:
    """action = the walker's action + extra (extra is 0 until the fault, NaN or late after it)."""
    graph = model.graph
    original = graph.output[0].name
    for node in graph.node:
        node.output[:] = [f"{original}_walker" if o == original else o for o in node.output]
    graph.node.append(helper.make_node("Add", [f"{original}_walker", extra], [original]))


def nan_when_fast(out: Path) -> Path:
    """0 * sqrt(FAIL_ABOVE - vx) added to every action: NaN once vx > FAIL_ABOVE_MPS."""
    model = onnx.load(str(LOCO))
    vx = _vx(model.graph)
    model.graph.node.extend([helper.make_node("Sub", ["fail_above", vx], ["headroom"]),
                             helper.make_node("Sqrt", ["headroom"], ["root"]),
                             helper.make_node("Mul", ["root", "zero"], ["nan_or_zero"])])
    _rewire(model, "nan_or_zero")
    onnx.save(model, str(out))
    return out


def slow_when_fast(out: Path, *, tick_s: float) -> Path:
    """A Loop of empty steps, none up to FAIL_ABOVE_MPS and a fixed count past it, whose count times 0 is added to
    every action: an inference of about ``tick_s`` from the first tick past that speed (a step, not a ramp: a walker
    slowed by degrees falls before it overruns). The count is measured on this machine (one inference with a known
    count) before the model is written."""
    probe = out.with_suffix(".probe.onnx")
    _slow(probe, 200_000)
    started = time.perf_counter()
    _infer(probe, 2 * FAIL_ABOVE_MPS)
    count = 200_000 * tick_s / (time.perf_counter() - started)
    probe.unlink()
    _slow(out, int(count))
    return out


def _infer(model: Path, vx: float) -> None:
    obs = np.zeros((1, 100), dtype=np.float32)
    obs[0, VX_AT] = vx
    ort.InferenceSession(str(model), providers=["CPUExecutionProvider"]).run(None, {"actor_obs": obs})


def _slow(out: Path, count: int) -> None:
    model = onnx.load(str(LOCO))
    graph = model.graph
    vx = _vx(graph)
    graph.initializer.extend([helper.make_tensor("steps", TensorProto.FLOAT, [], [float(count)]),
                              helper.make_tensor("always", TensorProto.BOOL, [], [True])])
    body = helper.make_graph(
        [helper.make_node("Identity", ["cond_in"], ["cond_out"]),
         helper.make_node("Add", ["acc_in", "one_in"], ["acc_out"])],
        "spin",
        [helper.make_tensor_value_info("i", TensorProto.INT64, []),
         helper.make_tensor_value_info("cond_in", TensorProto.BOOL, []),
         helper.make_tensor_value_info("acc_in", TensorProto.FLOAT, [])],
        [helper.make_tensor_value_info("cond_out", TensorProto.BOOL, []),
         helper.make_tensor_value_info("acc_out", TensorProto.FLOAT, [])],
        [helper.make_tensor("one_in", TensorProto.FLOAT, [], [1.0])])
    graph.node.extend([helper.make_node("Greater", [vx, "fail_above"], ["over"]),
                       helper.make_node("Cast", ["over"], ["over_f"], to=TensorProto.FLOAT),
                       helper.make_node("Mul", ["over_f", "steps"], ["count_f"]),
                       helper.make_node("Cast", ["count_f"], ["count_1"], to=TensorProto.INT64),
                       helper.make_node("Squeeze", ["count_1"], ["count"]),
                       helper.make_node("Loop", ["count", "always", "zero"], ["spun"], body=body),
                       helper.make_node("Mul", ["spun", "zero"], ["late_zero"])])
    _rewire(model, "late_zero")
    onnx.save(model, str(out))


def deploy_config(model: Path, out: Path) -> Path:
    """loco_ppo's deploy config pointing at ``model``."""
    raw = yaml.safe_load(builtin_configs()["loco_ppo"].read_text())
    raw["model"] = str(model)
    out.write_text(yaml.safe_dump(raw))
    return out
