"""Seeing a model: the reward graph and log analysis over the track.

- :mod:`drx.analysis.data`: a model's registry rows and its DeepRacer-layout trace files;
- :mod:`drx.analysis.reward_graph`: ``drx plot``;
- :mod:`drx.analysis.report` (with :mod:`~drx.analysis.track_plots`, :mod:`~drx.analysis.actions`,
  :mod:`~drx.analysis.iterations`): ``drx analyze``;
- :mod:`drx.analysis.eval_trace`: an evaluation's trace, written as training's.

Models leaving drx or coming in (packages, the car's ``model.pb``, DeepRacer's folder) are
:mod:`drx.interchange`'s.
"""
