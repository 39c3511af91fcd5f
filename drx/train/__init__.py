"""drx's trainer: Stable-Baselines3 PPO/SAC run as the DeepRacer console runs them.

Start with :class:`drx.train.trainer.Trainer` and :class:`~drx.train.trainer.TrainingSpec`;
``docs/TRAINING.md`` describes the loop, the networks, the checkpoints and the model folder.
"""
