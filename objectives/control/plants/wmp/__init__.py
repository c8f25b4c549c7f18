"""The wheeled mobile pendulum of the thesis (chapter 2) as one plant unit.

- :mod:`.model` (the 8-state model, eq. 2.12, its integrator and the closed-loop kernel with the sensors
  and the Kalman filter of eq. 2.20), :mod:`.params` (Table 2.1, Table 1.1);
- :mod:`.plant`: the ``Plant`` face and the registered kind ``wmp`` (family ``wmp``);
- :mod:`.controllers`: ``lqr``, ``lqg``, ``pid``, ``flc``, ``protective_fuzzy``, ``lut`` (registered in
  :data:`objectives.control.controllers.CONTROLLERS`);
- :mod:`.loop`: the loop the objective runs (profiles, eq. 2.39, the tracking requirements);
  :mod:`.profiles`, :mod:`.metrics` (eqs. 2.34-2.39), :mod:`.batch` (the population kernel of
  ``backend: threads``), :mod:`.report` (the run report's figures and traces).
"""
