"""Make a random DeepRacer checkpoint and its expected outputs, to self-test restore_check.py without drx.

Runs under ``.venv-tf`` only (``tools/tf_check/setup.sh``).

    .venv-tf/bin/python tools/tf_check/make_random_checkpoint.py --meta META --out DIR \\
        [--discrete N] [--batch 4] [--seed 0] [--perturb VAR]

Writes ``DIR/model/12_Step-3456.ckpt.{index,data-00000-of-00001}`` holding a random value for every online
trainable variable of the ``.meta`` graph (with ``--discrete N`` the continuous ``policy_mean`` and
``policy_log_std`` are replaced by ``ppo_head_0/policy_fc/{kernel,bias}`` [512,N], [N], the layout of a
discrete console model) and ``DIR/frames.npz`` (random uint8 frames and the graph's outputs for them,
computed with the weights loaded directly into the variables, not through the checkpoint).

The bundle is written by the ``SaveV2`` op alone: no ``.meta`` and no TensorFlow ``checkpoint`` state
file, which a DeepRacer model folder must not have (simapp ``multi_agent_graph_manager.py``
``restore_checkpoint`` raises NotImplementedError when a ``checkpoint`` file is present).

As a cross-check of the graph facts it also recomputes the outputs with numpy (x/255, VALID NHWC
convolutions 8x8/4, 4x4/2, 3x3/1 each + ReLU, row-major NHWC flatten, Dense 512 + ReLU, linear heads) and
prints the largest difference. ``--perturb VAR`` adds N(0, 0.05) noise to one checkpoint tensor after the
expected outputs were computed, so that restore_check must fail.
"""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np
from restore_check import INPUT, ONLINE, build

CKPT_NAME = "12_Step-3456.ckpt"
CONVS = (("Conv2d_0", 4), ("Conv2d_2", 2), ("Conv2d_4", 1))


def random_weights(variables, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """He-scaled kernels, small biases, rescalers 1.0 (their only trained value), log std in [-1, 0]."""
    weights = {}
    for v in variables:
        name, shape = v.op.name, v.shape.as_list()
        if name.endswith("_rescalers"):
            value = np.ones(shape)
        elif name.endswith("policy_log_std"):
            value = rng.uniform(-1.0, 0.0, shape)
        elif name.endswith("kernel"):
            value = rng.normal(0.0, np.sqrt(2.0 / np.prod(shape[:-1])), shape)
        else:
            value = rng.normal(0.0, 0.1, shape)
        weights[name] = value.astype(np.float32)
    return weights


def numpy_trunk(w: dict[str, np.ndarray], frames: np.ndarray, tower: str) -> np.ndarray:
    """DeepRacer's shallow trunk in float64 numpy: returns the 512-wide middleware output."""
    x = frames.astype(np.float64) / 255.0
    for conv, stride in CONVS:
        layer = f"{ONLINE}{tower}/FRONT_FACING_CAMERA/{conv}/"
        kernel, bias = w[layer + "kernel"], w[layer + "bias"]
        win = np.lib.stride_tricks.sliding_window_view(x, kernel.shape[:2], axis=(1, 2))
        win = win[:, ::stride, ::stride]  # VALID padding: windows start at multiples of the stride
        x = np.maximum(np.einsum("bhwcij,ijco->bhwo", win, kernel) + bias, 0.0)
    x = x.reshape(len(x), -1)
    dense = f"{ONLINE}{tower}/middleware_fc_embedder/Dense_0/"
    return np.maximum(x @ w[dense + "kernel"] + w[dense + "bias"], 0.0)


def numpy_outputs(w: dict[str, np.ndarray], frames: np.ndarray, discrete: int | None) -> dict:
    head = f"{ONLINE}network_1/ppo_head_0/"
    value = numpy_trunk(w, frames, "network_0") @ w[f"{ONLINE}network_0/v_values_head_0/output/kernel"]
    value = value[:, 0] + w[f"{ONLINE}network_0/v_values_head_0/output/bias"][0]
    mid = numpy_trunk(w, frames, "network_1")
    if discrete:
        logits = mid @ w[head + "policy_fc/kernel"] + w[head + "policy_fc/bias"]
        e = np.exp(logits - logits.max(axis=1, keepdims=True))
        return {"policy": np.maximum(e / e.sum(axis=1, keepdims=True), 1e-8), "value": value}
    return {"policy": mid @ w[head + "policy_mean/kernel"] + w[head + "policy_mean/bias"], "value": value}


def write_bundle(prefix: str, tensors: dict[str, np.ndarray]) -> None:
    """Write .index + .data-00000-of-00001 with the SaveV2 op (no meta graph, no 'checkpoint' file)."""
    import tensorflow as tf

    names = sorted(tensors)
    with tf.Graph().as_default(), tf.compat.v1.Session() as sess:
        sess.run(tf.raw_ops.SaveV2(prefix=prefix, tensor_names=names, shape_and_slices=[""] * len(names),
                                   tensors=[tf.constant(tensors[n]) for n in names]))
    stray = os.path.join(os.path.dirname(prefix), "checkpoint")
    if os.path.exists(stray):
        os.remove(stray)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--meta", required=True)
    parser.add_argument("--out", required=True, help="folder for model/ and frames.npz")
    parser.add_argument("--discrete", type=int, default=None, metavar="N")
    parser.add_argument("--batch", type=int, default=4)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--perturb", metavar="VAR", help="variable name (full or after online/) to perturb")
    args = parser.parse_args(argv)
    os.environ.setdefault("TF_CPP_MIN_LOG_LEVEL", "2")
    import tensorflow as tf

    rng = np.random.default_rng(args.seed)
    graph, variables, outputs = build(args.meta, args.discrete)
    weights = random_weights(variables, rng)
    frames = rng.integers(0, 256, (args.batch, 120, 160, 1), dtype=np.uint8)
    with tf.compat.v1.Session(graph=graph) as sess:
        sess.run(tf.compat.v1.global_variables_initializer())
        for v in variables:
            v.load(weights[v.op.name], sess)
        got = sess.run(outputs, {graph.get_tensor_by_name(INPUT): frames.astype(np.float32)})
    expected = {"frames": frames, "policy": got["policy"], "value": got["value"][:, 0]}
    if not args.discrete:
        expected["log_std"] = got["log_std"].reshape(-1)
    ref = numpy_outputs(weights, frames, args.discrete)
    for key in ("policy", "value"):
        diff = np.max(np.abs(ref[key] - expected[key]))
        print(f"numpy reference vs TF graph: {key} max_abs_diff={diff:.3e}")

    if args.perturb:
        name = args.perturb if args.perturb.startswith(ONLINE) else ONLINE + args.perturb
        if name not in weights:
            print(f"no variable {name}")
            return 2
        noise = rng.normal(0.0, 0.05, weights[name].shape)  # not uniform: softmax ignores a common shift
        weights[name] = (weights[name] + noise).astype(np.float32)
        print(f"perturbed {name} by N(0, 0.05) noise after computing the expected outputs")
    model = os.path.join(args.out, "model")
    os.makedirs(model, exist_ok=True)
    write_bundle(os.path.join(model, CKPT_NAME), weights)
    np.savez(os.path.join(args.out, "frames.npz"), **expected)
    print(f"wrote {len(weights)} tensors to {os.path.join(model, CKPT_NAME)} and {args.out}/frames.npz")
    print("files:", sorted(os.listdir(model)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
