"""Benchmarks from outside the project, seen through :class:`~sb3_comm.wrappers.TwoAgentEnv`.

* :mod:`~sb3_comm.foreign.simple_reference`: mpe2's ``simple_reference`` with its own channel
  silenced (``MPESimpleReference-v0``), and its scripted references. Needs the ``mpe`` extra.
* :mod:`~sb3_comm.foreign.batched_simple_reference`: the same game re-implemented in numpy for N
  games at once (what :func:`sb3_comm.make_comm_vec_env` builds for that id; no mpe2 needed),
  tested against mpe2 step for step.

They live in ``sb3_comm`` rather than ``envs`` because they are built from sb3-comm's wrappers
(``envs`` does not depend on ``sb3_comm``).
"""
