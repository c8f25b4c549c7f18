"""MuJoCo models as plants: tune joint PIDs and LQRs on the MJCF or URDF model a robot already has.

The plant unit of the ``mujoco`` kind and loop family (optional extra ``.[mujoco]``; nothing here imports
MuJoCo at import time, so everything else works without it). YAML (``objective.plant``)::

    mujoco: cartpole.xml        # MJCF, or URDF compiled by MuJoCo (relative to the config's folder)
    actuators: [push]           # the controller's outputs -> these actuators (default: every actuator)
    motors: [shoulder, elbow]   # add a motor actuator on each of these joints (a URDF has none)
    outputs:                    # the measured outputs (default: every named hinge/slide joint's position)
      - cart                    #   a joint's position or a scalar sensor, by name
      - {joint_velocity: hinge}
      - {sensor: imu_gyro, index: 1}
      - {body: pole, angle: pitch, name: tilt}   # roll | pitch | yaw of a body's orientation
    state_joints: [slider, hinge]  # the state of lqr_fd: these joints' dofs and velocities (default: all)
    keyframe: upright           # initial state and operating point (default: qpos0 at rest)
    qpos: [...]                 # or given (nq values; qvel nv values, ctrl nu values)
    timestep_s: 0.002           # the engine's timestep (default: the model's); period_s is a multiple of it
    ctrlrange: {push: [-10, 10]}   # saturation (default: the model's ctrlrange where ctrllimited)
    loops: [[shoulder, shoulder]]  # joint_pid's loops [output, actuator] (default: output i -> actuator i)
    parameters: {body.pole.mass: 0.12}   # named parameters set before anything else (.parameters)

Modules: :mod:`.plant` (the registered kind), :mod:`.model` (building and checking the plant, the ``Plant``
protocol), :mod:`.parameters` (named physical parameters), :mod:`.linearize` (MuJoCo's finite-difference
linearisation over a controller period), :mod:`.capi` (MuJoCo's C functions for the compiled loop),
:mod:`.kernel` (the compiled loop), :mod:`.controllers` (``joint_pid``, ``lqr_fd``), :mod:`.scenario`,
:mod:`.uncertainty`, :mod:`.loop` (the family's loop), :mod:`.batch` (threads), :mod:`.report`.
"""
