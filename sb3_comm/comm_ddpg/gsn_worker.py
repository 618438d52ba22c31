"""A second process that performs the GSN's updates beside the agents' updates.

A GSN update reads only the GSN and its own batch, and an agent update never reads the GSN, so the
two can run at the same time. On a thread they barely do (each small torch operation holds
Python's GIL for about as long as its kernel runs, and two threads mostly wait for each other);
in a second process they do: the GSN's parameters, buffers and optimizer state are moved to
shared memory, the process is forked from the trainer, and every ``train`` call sends it the
batches (drawn on the trainer, in the usual order of the random stream) and the learning rate,
then collects the values to log once the agents' updates are done. The update itself is the
callback's own code (:meth:`GSNTrainingCallback._updates
<sb3_comm.comm_ddpg.gsn.GSNTrainingCallback._updates>`) on the same tensors, so a run is the same,
to the bit, as when the GSN trains after the agents in the trainer.

The worker lives for one ``learn`` call (it is forked anew at the next one, so that it always
shares the tensors the model holds then). It is used on Linux, on the CPU, where a core is spare;
elsewhere the GSN trains after the agents in the trainer.
"""

from __future__ import annotations

import multiprocessing as mp
import sys
import traceback
from multiprocessing.connection import Connection
from types import SimpleNamespace
from typing import Any

import numpy as np
import torch as th

__all__ = ["GSN_BATCH_FIELDS", "GSNWorker", "can_fork"]


def can_fork() -> bool:
    """Whether this process can fork a worker: on Linux (macOS and Windows do not fork safely),
    and not from a daemonic process (a ``multiprocessing`` pool's worker may have no children)."""
    return (
        sys.platform.startswith("linux")
        and "fork" in mp.get_all_start_methods()
        and not mp.current_process().daemon
    )


def share_training_state(module: th.nn.Module, optimizers: list[th.optim.Optimizer]) -> None:
    """Move ``module``'s parameters and buffers and the optimizers' state tensors to shared memory,
    in place (every tensor object stays the one the model and the optimizers hold)."""
    module.share_memory()
    for optimizer in optimizers:
        for state in optimizer.state.values():
            for value in state.values():
                if isinstance(value, th.Tensor):
                    value.share_memory_()


def optimizer_state_complete(optimizer: th.optim.Optimizer) -> bool:
    """Whether every parameter of ``optimizer`` has its state (an optimizer creates it at its first
    step: state made after the fork would stay in the worker)."""
    return all(
        len(optimizer.state.get(p, {})) > 0 for group in optimizer.param_groups for p in group["params"]
    )


GSN_BATCH_FIELDS = ("observations", "actions", "rewards")
"""What a GSN update reads of a replay batch."""


def _worker_main(
    connection: Connection, parent_end: Connection, callback: Any, slots: dict[str, th.Tensor]
) -> None:
    """The worker's loop: one job per ``train`` call, until ``None``."""
    parent_end.close()
    th.set_num_threads(1)
    model = callback.model
    # The replay buffer's arrays were inherited copy-on-write: let them go here (whoever else holds
    # the buffer, e.g. SB3's callback locals), so that the trainer's writes into them do not
    # duplicate the pages the worker does not need.
    buffer = model.replay_buffer
    for name, value in list(vars(buffer).items()) if buffer is not None else []:
        if isinstance(value, np.ndarray):
            setattr(buffer, name, None)
    gsn = model.policy.gsn
    try:
        while True:
            job = connection.recv()
            if job is None:
                break
            learning_rate, batches = job
            try:
                gsn.train(True)
                for group in gsn.optimizer.param_groups:
                    group["lr"] = learning_rate
                if isinstance(batches, int):  # that many batches in the shared slots
                    batches = [
                        SimpleNamespace(**{name: slots[name][i] for name in GSN_BATCH_FIELDS})
                        for i in range(batches)
                    ]
                else:  # arrays sent through the pipe
                    batches = [
                        SimpleNamespace(
                            **dict(zip(GSN_BATCH_FIELDS, map(th.from_numpy, arrays), strict=True))
                        )
                        for arrays in batches
                    ]
                values = callback._updates(batches)
                reply = ("ok", [(key, float(value), count) for key, value, count in values])
            except Exception:  # sent to the trainer, which raises it
                reply = ("error", traceback.format_exc())
            connection.send(reply)
    except (EOFError, KeyboardInterrupt):  # the trainer went away, or Ctrl-C reached the group
        pass
    finally:
        connection.close()


class GSNWorker:
    """A forked process that runs :class:`~sb3_comm.comm_ddpg.gsn.GSNTrainingCallback`'s GSN
    updates on tensors shared with the trainer.

    Batches travel through shared slots (as many as ``capacity``, each shaped like ``example``);
    a call with more batches, or batches of another shape, sends them through the pipe.

    :param callback: the callback whose model's GSN the worker trains. The GSN's optimizer must
        already hold its state (:func:`optimizer_state_complete`).
    :param example: a batch of the kind the worker will train on.
    :param capacity: batches per call that the shared slots hold.
    """

    def __init__(self, callback: Any, example: Any, capacity: int = 1) -> None:
        gsn = callback.model.policy.gsn
        if not optimizer_state_complete(gsn.optimizer):
            raise RuntimeError("the GSN optimizer has no state yet: make one update before the worker starts")
        share_training_state(gsn, [gsn.optimizer])
        fields = {name: getattr(example, name) for name in GSN_BATCH_FIELDS}
        self._slots = {
            name: th.empty((capacity, *value.shape), dtype=value.dtype, device="cpu").share_memory_()
            for name, value in fields.items()
        }
        context = mp.get_context("fork")
        self._connection, child_end = context.Pipe()
        self._process = context.Process(
            target=_worker_main,
            args=(child_end, self._connection, callback, self._slots),
            name="gsn-worker",
            daemon=True,
        )
        self._process.start()
        child_end.close()
        self._pending = False

    @property
    def alive(self) -> bool:
        """Whether the worker process is running."""
        return self._process.is_alive()

    def submit(self, learning_rate: float, batches: list[Any]) -> None:
        """Start the updates on ``batches`` (the fields ``observations``, ``actions``, ``rewards``)."""
        slots = self._slots
        fits = len(batches) <= len(slots["rewards"]) and all(
            getattr(b, name).shape == slots[name].shape[1:] and getattr(b, name).dtype == slots[name].dtype
            for b in batches
            for name in GSN_BATCH_FIELDS
        )
        if fits:
            for i, batch in enumerate(batches):
                for name in GSN_BATCH_FIELDS:
                    slots[name][i].copy_(getattr(batch, name))
            job: Any = len(batches)
        else:
            job = [
                tuple(getattr(b, name).detach().cpu().numpy() for name in GSN_BATCH_FIELDS) for b in batches
            ]
        try:
            self._connection.send((learning_rate, job))
        except (BrokenPipeError, OSError) as error:
            raise RuntimeError(self._died_message()) from error
        self._pending = True

    def result(self) -> list[tuple[str, float, int]]:
        """Wait for the submitted updates; the values to log. Re-raises an error of the worker."""
        self._pending = False
        try:
            status, payload = self._connection.recv()
        except (EOFError, OSError) as error:
            raise RuntimeError(self._died_message()) from error
        if status == "error":
            raise RuntimeError(f"a GSN update failed in the worker process:\n{payload}")
        return payload

    def close(self) -> None:
        """Stop the worker (after collecting any pending result, which is dropped)."""
        try:
            if self._pending:
                self.result()
            self._connection.send(None)
        except (RuntimeError, BrokenPipeError, OSError):
            pass
        self._process.join(timeout=10)
        if self._process.is_alive():
            self._process.terminate()
            self._process.join()
        self._connection.close()

    def _died_message(self) -> str:
        self._process.join(timeout=1)
        return f"the GSN worker process died (exit code {self._process.exitcode})"
