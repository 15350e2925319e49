"""Running a plan: results read back from a store, the rest run by an executor, gathered in task order."""

from __future__ import annotations

from collections.abc import Callable

from sensorsel.pipeline.executors import Executor, InProcess
from sensorsel.pipeline.plan import Plan, R
from sensorsel.pipeline.store import NoStore, Store


def execute(
    plan: Plan[R],
    executor: Executor | None = None,
    store: Store[R] | None = None,
    progress: Callable[[int, int], None] | None = None,
    on_result: Callable[[int, R, bool], None] | None = None,
) -> list[R]:
    """Every task's result, in task order: read back from ``store`` where it holds a matching one,
    else run by ``executor`` (default: in this process) and put in ``store`` as it arrives.

    Args:
        progress: ``progress(done, total)`` once for the results read back, then after each task.
        on_result: ``on_result(i, result, reused)`` for each task's result as it arrives; ``reused``:
            read back from the store (those come first).

    Raises:
        SensorselError: a task failed (on a cluster: :class:`ClusterError` naming the task).
    """
    ex = executor if executor is not None else InProcess()
    st: Store[R] = store if store is not None else NoStore()
    n = len(plan.tasks)
    got: dict[int, R] = {}
    for i in range(n):
        old = st.get(i)
        if old is not None:
            got[i] = old
            if on_result:
                on_result(i, old, True)
    if progress and got:
        progress(len(got), n)

    def done(i: int, result: R) -> None:
        st.put(i, result)
        got[i] = result
        if on_result:
            on_result(i, result, False)
        if progress:
            progress(len(got), n)

    ex.run(plan, [i for i in range(n) if i not in got], done)
    missing = [i for i in range(n) if i not in got]
    if missing:
        raise AssertionError(f"the executor left {plan.name}s {missing} unrun")
    return [got[i] for i in range(n)]
