"""drx's own model package (``drx model export``): manifest, checkpoint, ONNX policy, reward."""
