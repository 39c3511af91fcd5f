"""Time trials, the local leaderboard, lap videos and the theoretical best lap.

- :mod:`~drx.evaluate.time_trial`: the time-trial rules engine (laps, off-track penalties, resets, time cap).
- :mod:`~drx.evaluate.policy`: a checkpoint's policy (most probable action); which checkpoint to use:
  :mod:`drx.services.checkpoints`.
- :mod:`~drx.evaluate.scripted`: geometric drivers (pure pursuit) for tests and benchmarks.
- :mod:`~drx.evaluate.service`: check a request, run it, store it; read evaluations back.
- Queued evaluations (``drx evaluate --detach``) are jobs of the queue: :mod:`drx.queue.evaluate_job`.
- :mod:`~drx.evaluate.ranking` / :mod:`~drx.evaluate.leaderboard`: ranking modes and the leaderboard.
- :mod:`~drx.evaluate.video`: MP4/GIF lap videos.
- :mod:`~drx.evaluate.racing_line`, :mod:`~drx.evaluate.boxqp`, :mod:`~drx.evaluate.speed_profile`,
  :mod:`~drx.evaluate.theoretical_lap`, :mod:`~drx.evaluate.theoretical_lap_plot`: the theoretical best lap.
"""
