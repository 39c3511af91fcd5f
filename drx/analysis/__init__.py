"""Seeing and shipping a model: the reward graph, log analysis over the track, and packages.

- :mod:`drx.analysis.data`: a model's registry rows and its DeepRacer-layout trace files;
- :mod:`drx.analysis.reward_graph`: ``drx plot``;
- :mod:`drx.analysis.report` (with :mod:`~drx.analysis.track_plots`, :mod:`~drx.analysis.actions`,
  :mod:`~drx.analysis.iterations`): ``drx analyze``;
- :mod:`drx.analysis.model_package`, :mod:`drx.analysis.importer`, :mod:`drx.analysis.onnx_policy`,
  :mod:`drx.analysis.safe_tar`: ``drx model export|import``.
"""
