"""drx's car held against DeepRacer's own: reading DeepRacer's logs, replaying them, fitting the car.

- :mod:`.logs`: the one reader of DeepRacer's step traces (robomaker logs, sim-trace CSVs, every
  layout from the console of 2019 to DeepRacer on AWS), and the shared calibration log sets;
- :mod:`.log_metadata`: what a log says of the simulator that recorded it and of its action space;
- :mod:`.replay`, :mod:`.replay_plot`: open-loop replay of logged commands through drx's car;
- :mod:`.step_jitter`: the car's step-to-step timing, measured from the distances it covers;
- :mod:`.fidelity`: the figures and targets of ``benchmarks/replay_fidelity.py``;
- :mod:`.fit`, :mod:`.calibration_module`: the fitting core of ``tools/fit_car_model.py`` and the
  writer of its result, ``drx/sim/car_calibration.py`` (the simulator's constants stay in
  :mod:`drx.sim`, which never imports this package).
"""
