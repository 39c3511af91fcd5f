"""A model's settings as typed, validated objects: hyperparameters, stop conditions, race, rollout.

The registry stores them as JSON and hands them out as these objects; the trainer, the queue and
the CLI take them. Nothing here imports torch, SQLAlchemy or the simulator.
"""
