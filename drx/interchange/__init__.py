"""Every way a model leaves drx or comes in, by destination.

- :mod:`drx.interchange.car`: the physical car's ``model.pb`` (``drx model export --for-car``):
  the policy as a TensorFlow graph written without TensorFlow (``car_graph``, ``tf_graph``), the
  car's package and its loader's rules (``car_package``), and a DeepRacer ``model.pb`` run by
  OpenVINO as the car runs it (``openvino_policy``);
- :mod:`drx.interchange.package`: drx's own package (``drx model export``): the manifest and
  archive (``model_package``), the policy as ONNX (``onnx_policy``) and the layers both graph
  writers walk (``policy_parts``);
- :mod:`drx.interchange.importers`: ``drx model import`` of a drx package or a DeepRacer car
  archive (``model_import``, ``importer``, ``deepracer_import``);
- :mod:`drx.interchange.deepracer`: DeepRacer's model folder (``--for-deepracer`` and its import):
  TensorFlow checkpoints without TensorFlow, distillation into DeepRacer's network, locations;
- :mod:`drx.interchange.safe_tar`: the one reader and writer of archives.

The package sits below :mod:`drx.evaluate` (an evaluation drives a ``model.pb`` or an ONNX
policy), so nothing here imports the evaluation: the export races on the course its caller
hands it (docs/CONTRACTS.md, Layers).
"""
