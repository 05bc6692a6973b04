"""Gymnasium environments. Everything here may import pybullet (through ``tactile_gym.sim``).

One env class per file, serving every version of its ids, joined from parts that know nothing
of each other (``docs/design.md`` 7):

* ``hinge_probe``: ``HingeProbeEnv``, the 6-D ids, and ``HingeProbeConfig``.
* ``hinge_probe_primitive``: the primitive ids, a ``gym.Wrapper`` over the 6-D env.
* ``hinge_probe_v1``, ``hinge_probe_primitive_v1``: the old names of the two above, deprecated
  aliases until 0.5.
* ``vector``: the vector env of every id (N sub-envs, in this process or in worker processes).
* ``controller``: normalised actions to fingertip pose targets.
* ``measurement``: the measurement pipeline (touch sensing, the gate, the estimator); the
  only module here that imports the probing stack.
* ``observation``: the observation codec (every entry by name).
* ``task``: reward, success and termination.
* ``scenarios``: the reset distribution.
* ``skills``: closed-loop probing motions over observations (the primitives, the baselines).
* ``step_guard``: the step rules every id shares.
* ``plotting``: top views in the style of the paper's figures.
"""
