"""drx's trainer: Stable-Baselines3 PPO/SAC run as the DeepRacer console runs them.

Start with :class:`drx.train.trainer.Trainer` and :class:`~drx.train.trainer.TrainingSpec`;
``docs/TRAINING.md`` describes the loop, the networks, the checkpoints and the model folder.
"""

import os

# OpenMP threads that spin while waiting for a descheduled partner make torch's multi-threaded
# update several times slower on a busy machine (docs/TRAINING.md); passive waiting costs nothing
# measurable on an idle one. It must be set before torch loads (the CLI loads torch lazily).
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
