"""Learned policies as controllers of the node's loop: a deploy config and an ONNX model (onnxruntime, CPU)."""
