"""DeepRacer's model folder, out of drx and back in.

The folder that deepracer-for-cloud uploads and DeepRacer on AWS imports (``model_metadata.json``,
``reward_function.py``, ``training_params.yaml``, hyperparameters, metrics, and in ``model/`` a
TensorFlow checkpoint of DeepRacer's two-tower network), written and read without TensorFlow.
"""
