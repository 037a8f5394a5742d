"""An ONNX policy model on onnxruntime's CPU provider, one thread (the node shares two cores with DDS and, on the
sim, the physics), with its metadata and the sizes of its inputs and outputs read once."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import onnxruntime as ort

from g1_mode_manager.core.controller.interface import ControllerError


class PolicyModel:
    def __init__(self, path: Path) -> None:
        options = ort.SessionOptions()
        options.intra_op_num_threads = 1
        options.inter_op_num_threads = 1
        try:
            self._session = ort.InferenceSession(str(path), options, providers=["CPUExecutionProvider"])
        except Exception as exc:  # onnxruntime raises its own classes for a missing, truncated or invalid file
            raise ControllerError(f"model {path} cannot be loaded: {exc}") from exc
        self.path = path
        self.metadata: dict[str, str] = dict(self._session.get_modelmeta().custom_metadata_map)
        self.inputs = {i.name: _width(i.shape) for i in self._session.get_inputs()}
        self.outputs = {o.name: _width(o.shape) for o in self._session.get_outputs()}

    def run(self, outputs: list[str], feeds: dict[str, np.ndarray]) -> list[np.ndarray]:
        return self._session.run(outputs, feeds)


def _width(shape: list[object]) -> int:
    """The size of a [1, N] tensor (0 where the model leaves it symbolic)."""
    last = shape[-1] if shape else 0
    return last if isinstance(last, int) else 0
