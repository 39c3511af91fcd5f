"""``drx sweep``: hyperparameter sweeps with Optuna, stored in the registry, trained by the queue."""
