"""Restore a DeepRacer checkpoint into DeepRacer's own TensorFlow graph and compare its outputs.

Runs under ``.venv-tf`` only (``tools/tf_check/setup.sh``); TensorFlow is a check tool, never a drx
dependency, and this script never imports drx.

    .venv-tf/bin/python tools/tf_check/restore_check.py --meta META --checkpoint PREFIX \\
        --frames frames.npz [--discrete N] [--atol 1e-4] [--json]

Why this is the simulator's way: DeepRacer's simapp never reads the ``.meta`` (it rebuilds the graph in
code) nor uses ``Saver.restore``. Its patched rl_coach ``GlobalVariableSaver``
(deepracer-simapp ``bundle/rl_coach/rl_coach/architectures/tensorflow_components/savers.py``, before 2026
the same code as ``bundle/rl_coach.patch`` over rl_coach 1.0.0) keeps ``tf.compat.v1.trainable_variables()``
minus ``/target``, reads the bundle with ``tf.compat.v1.train.load_checkpoint`` and assigns each
variable the tensor of the same name through a placeholder; a variable missing from the checkpoint is a
KeyError, which ``restore_checkpoint`` (``bundle/markov/multi_agent_coach/multi_agent_graph_manager.py``)
re-raises as "Failed to restore agent's checkpoint". Extra checkpoint tensors are ignored. The target
network and Adam slots are only initialised. We do the same on the graph rl_coach exported (``.meta``).

Graph facts used here (from the console model's ``.meta``): the camera placeholder takes float32 grey
pixels 0..255 [B,120,160,1] and the graph itself divides by 255 (``truediv`` then ``sub 0``); the policy
tower reads network_0's placeholder too. For ``--discrete N`` the ``.meta`` head is continuous, so a
``policy_fc`` head is built on the ppo head's input like simapp's ``ppo_head.py`` ``_build_discrete_net``:
``maximum(softmax(x @ kernel + bias), 1e-8)``; the continuous-only variables are then not restored.
Exit codes: 0 all within --atol, 1 a difference or a failed restore, 2 bad input.
"""

from __future__ import annotations

import argparse
import json
import os
import sys

import numpy as np

ONLINE = "main_level/agent/main/online/"
INPUT = ONLINE + "network_0/FRONT_FACING_CAMERA/FRONT_FACING_CAMERA:0"
POLICY = ONLINE + "network_1/ppo_head_0/policy:0"  # Identity(policy_mean/BiasAdd): the mean, no tanh
VALUE = ONLINE + "network_0/v_values_head_0/output/BiasAdd:0"  # [B, 1]
LOG_STD = ONLINE + "network_1/ppo_head_0/policy_log_std:0"  # variable [1, A]
HEAD_INPUT = ONLINE + "network_1/ppo_head_0/strided_slice:0"  # 512-wide ReLU after the grad rescaler
FC_SCOPE = ONLINE + "network_1/ppo_head_0/policy_fc"
CONTINUOUS_ONLY = {
    ONLINE + "network_1/ppo_head_0/policy_mean/kernel",
    ONLINE + "network_1/ppo_head_0/policy_mean/bias",
    ONLINE + "network_1/ppo_head_0/policy_log_std",
}
ZERO_OFFSET = 1e-8  # simapp ppo_head.py: tf.maximum(tf.nn.softmax(...), ZERO_OFFSET)


class CheckError(Exception):
    """A failed check (exit 1) as opposed to bad input (exit 2)."""


def build(meta: str, discrete: int | None):
    """Import the meta graph (plus a discrete head); return (graph, variables to restore, outputs)."""
    import tensorflow as tf

    tf.get_logger().setLevel("ERROR")  # silence TF1-API deprecation notes
    tf.compat.v1.disable_eager_execution()
    tf.compat.v1.disable_resource_variables()  # as simapp's savers.py; the .meta holds VariableV2 ops
    graph = tf.Graph()
    with graph.as_default():
        tf.compat.v1.train.import_meta_graph(meta, clear_devices=True)
        outputs = {"policy": graph.get_tensor_by_name(POLICY), "value": graph.get_tensor_by_name(VALUE)}
        if discrete:
            head_in = graph.get_tensor_by_name(HEAD_INPUT)
            with tf.compat.v1.variable_scope(FC_SCOPE):
                kernel = tf.compat.v1.get_variable("kernel", [int(head_in.shape[-1]), discrete], tf.float32)
                bias = tf.compat.v1.get_variable("bias", [discrete], tf.float32)
            probs = tf.nn.softmax(tf.matmul(head_in, kernel) + bias, name="policy")
            outputs["policy"] = tf.maximum(probs, ZERO_OFFSET)
        else:
            outputs["log_std"] = graph.get_tensor_by_name(LOG_STD)
        skip = CONTINUOUS_ONLY if discrete else set()
        variables = [
            v for v in tf.compat.v1.trainable_variables()
            if v.op.name.startswith(ONLINE) and v.op.name not in skip
        ]
    return graph, variables, outputs


def restore(sess, graph, variables, prefix: str) -> list[str]:
    """Initialise everything, then assign the online variables by name; return unused checkpoint names."""
    import tensorflow as tf

    try:
        reader = tf.compat.v1.train.load_checkpoint(prefix)
        shapes = reader.get_variable_to_shape_map()
    except (tf.errors.OpError, ValueError) as err:
        raise CheckError(f"cannot read {prefix}: {err}") from err
    feed, ops = {}, []
    with graph.as_default():
        sess.run([tf.compat.v1.global_variables_initializer(), tf.compat.v1.local_variables_initializer()])
        for v in variables:
            name, want = v.op.name, v.shape.as_list()
            if name not in shapes:
                raise CheckError(f"checkpoint has no tensor {name} {want}")
            if list(shapes[name]) != want:
                raise CheckError(f"checkpoint tensor {name} has shape {shapes[name]}, the graph wants {want}")
            try:
                value = reader.get_tensor(name)
            except tf.errors.OpError as err:
                raise CheckError(f"cannot read tensor {name}: {err}") from err
            if value.dtype != np.float32:
                raise CheckError(f"checkpoint tensor {name} is {value.dtype}, the graph wants float32")
            ph = tf.compat.v1.placeholder(tf.float32, want)
            ops.append(tf.compat.v1.assign(v, ph))
            feed[ph] = value
        sess.run(ops, feed)
    return sorted(set(shapes) - {v.op.name for v in variables})


def load_frames(path: str, discrete: int | None) -> dict[str, np.ndarray]:
    """Read and validate frames.npz; raise ValueError with one sentence on bad input."""
    with np.load(path) as z:
        data = {k: z[k] for k in z.files}
    for key in ("frames", "policy", "value"):
        if key not in data:
            raise ValueError(f"{path} has no array '{key}'")
    frames, policy, value = data["frames"], data["policy"], data["value"]
    if frames.dtype != np.uint8 or frames.ndim != 4 or frames.shape[1:] != (120, 160, 1):
        raise ValueError(f"frames must be uint8 [B,120,160,1], got {frames.dtype} {list(frames.shape)}")
    batch, actions = frames.shape[0], discrete or 2
    if policy.shape != (batch, actions):
        raise ValueError(f"policy must be [{batch},{actions}], got {list(policy.shape)}")
    if value.shape != (batch,):
        raise ValueError(f"value must be [{batch}], got {list(value.shape)}")
    if "log_std" in data and (discrete or data["log_std"].shape != (actions,)):
        raise ValueError(f"log_std must be [{actions}] and only for a continuous model")
    return data


def run_check(
    meta: str, prefix: str, data: dict[str, np.ndarray], discrete: int | None, atol: float, rtol: float = 0.0
) -> dict:
    """Restore, run the towers on the frames, and compare each quantity with the expected array."""
    import tensorflow as tf

    try:
        graph, variables, outputs = build(meta, discrete)
    except Exception as err:  # an unreadable or foreign .meta is bad input, not a failed check
        raise ValueError(f"cannot use {meta} as DeepRacer's graph: {err}") from err
    with tf.compat.v1.Session(graph=graph) as sess:
        unused = restore(sess, graph, variables, prefix)
        feed = {graph.get_tensor_by_name(INPUT): data["frames"].astype(np.float32)}  # 0..255, graph /255
        got = sess.run(outputs, feed)
    got["value"] = got["value"][:, 0]
    result = {"atol": atol, "rtol": rtol, "restored": len(variables), "unused_checkpoint_tensors": unused,
              "quantities": {}}  # fmt: skip
    for key in ("policy", "value", "log_std"):
        if key in data and key in got:
            want = data[key].astype(np.float32)
            error = np.abs(got[key].reshape(want.shape) - want)
            ok = bool(np.all(error <= atol + rtol * np.abs(want)))  # numpy's isclose rule
            result["quantities"][key] = {"max_abs_diff": float(np.max(error)), "ok": ok}
    result["ok"] = all(q["ok"] for q in result["quantities"].values())
    return result


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--meta", required=True, help="DeepRacer's N_Step-M.ckpt.meta (rl_coach graph)")
    parser.add_argument("--checkpoint", required=True, help="checkpoint prefix, e.g. model/12_Step-3456.ckpt")
    parser.add_argument("--frames", required=True, help="npz: frames uint8 [B,120,160,1], policy, value")
    parser.add_argument("--discrete", type=int, default=None, metavar="N", help="N discrete actions")
    parser.add_argument("--atol", type=float, default=1e-4)
    parser.add_argument(
        "--rtol", type=float, default=0.0,
        help="relative tolerance: a value head's returns run into the hundreds",
    )  # fmt: skip
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    args = parser.parse_args(argv)

    def bad(msg: str) -> int:
        print(json.dumps({"ok": False, "error": msg}) if args.json else f"bad input: {msg}")
        return 2

    bundle = (args.checkpoint + ".index", args.checkpoint + ".data-00000-of-00001")
    for path in (args.meta, *bundle, args.frames):
        if not os.path.isfile(path):
            return bad(f"{path} does not exist")
    if args.discrete is not None and args.discrete < 2:
        return bad("--discrete needs at least 2 actions")
    try:
        data = load_frames(args.frames, args.discrete)
    except (ValueError, OSError) as err:
        return bad(str(err))
    os.environ.setdefault("TF_CPP_MIN_LOG_LEVEL", "2")
    try:
        import tensorflow  # noqa: F401
    except ImportError:
        return bad("tensorflow is not importable; run under .venv-tf (tools/tf_check/setup.sh)")
    try:
        result = run_check(args.meta, args.checkpoint, data, args.discrete, args.atol, args.rtol)
    except CheckError as err:
        result = {"ok": False, "error": f"restore failed: {err}"}
    except ValueError as err:
        return bad(str(err).splitlines()[0])
    if args.json:
        print(json.dumps(result, indent=2))
    elif "error" in result:
        print(result["error"])
    else:
        print(f"restored {result['restored']} online variables; unused checkpoint tensors: "
              f"{len(result['unused_checkpoint_tensors'])}")
        for key, q in result["quantities"].items():
            print(f"{key:8s} max_abs_diff={q['max_abs_diff']:.3e} {'ok' if q['ok'] else 'FAIL'}")
        print("PASS" if result["ok"] else f"FAIL (atol {args.atol})")
    return 0 if result["ok"] else 1


if __name__ == "__main__":
    sys.exit(main())
