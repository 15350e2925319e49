"""A design run as a plan of tasks (run by :func:`sensorsel.pipeline.execute`)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, Generic, TypeVar

#: a task's result
R = TypeVar("R")


@dataclass(frozen=True)
class Plan(Generic[R]):
    """The tasks of one design run, written once for every executor.

    Attributes:
        name: what one task is, in messages ("period", "study cell", "tradespace rule").
        step: ``step(state, task) -> result``: runs one task on its state. A module-level function
            (it is pickled by name to reach a worker); deterministic, so a task rerun elsewhere after
            a lost worker gives the same bytes.
        tasks: the task messages, small and picklable (numbers, names, dataclasses of a few fields);
            the results come back in this order.
        states: what the tasks run on, as it is sent to a worker: the state itself, or a recipe of it
            when ``build`` is given (a linearized problem does not pickle; its recipe does).
        build: ``build(recipe) -> state``, run once per state where the tasks run; None: ``states``
            are the states themselves.
        state_of: for each task, the index of its state in ``states`` (default: all on state 0).
            Tasks are in state order where memory matters: in-process, one built state is kept at a time.
        local: the states this process already holds (same order as ``states``), used instead of
            building them when the tasks run here (e.g. an evaluator the caller built).
    """

    name: str
    step: Callable[[Any, Any], R]
    tasks: Sequence[Any]
    states: Sequence[Any] = (None,)
    build: Callable[[Any], Any] | None = None
    state_of: Sequence[int] | None = None
    local: Sequence[Any] | None = field(default=None, compare=False)

    def state_index(self, i: int) -> int:
        """The index in :attr:`states` of task ``i``'s state."""
        return 0 if self.state_of is None else int(self.state_of[i])
