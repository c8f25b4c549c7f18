"""The wheeled mobile pendulum's controllers (thesis chapter 2): ``lqr``, ``lqg`` (:mod:`.lqr`), ``pid``
(:mod:`.pid`), ``flc``, ``protective_fuzzy``, ``lut`` (:mod:`.fuzzy`), their numba steps (:mod:`.kernels`,
:mod:`.fuzzy_steps`) and their common base (:mod:`.base`).

They are registered, like every controller, in :data:`objectives.control.controllers.CONTROLLERS`; their
``family`` (``"wmp"``) says that they run in the pendulum's own loop (:mod:`objectives.control.plants.wmp.loop`).
"""
