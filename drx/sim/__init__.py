"""drx's simulator: DeepRacer tracks, car dynamics, reward ``params``, camera and the Gymnasium env.

Import the pieces from their modules (``drx.sim.track``, ``drx.sim.env``...);
this package file stays light so that ``import drx`` does not pull OpenCV in.
"""
