"""What ``station serve`` computes from the results database (a figure's statistics, its
SVG charts), computed once per database state and kept: the key of each answer names the
page, its filters and :func:`station.services.line.line_state`, so a grading stored makes
a new key and the old answers age out.

The work runs in a pool of :data:`RENDER_WORKERS` threads, so that many clients asking at
once queue for the pool rather than each drawing a chart of its own; a second request for
an answer being computed waits for that one computation (it is not started twice).
"""

from __future__ import annotations

import asyncio
import threading
from collections import OrderedDict
from collections.abc import Callable, Hashable
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any

#: Threads that compute answers (statistics, charts) at once.
RENDER_WORKERS = 2
#: Answers kept (the least recently used go first).
ANSWERS_KEPT = 256


class RenderCache:
    """Answers computed once per key in a bounded pool, the newest :data:`ANSWERS_KEPT` kept.

    :meth:`get` is a coroutine, and may be awaited from any event loop and thread (a
    server has one loop; a test client may run a loop per request): the computations run
    in the pool's threads, the books are kept under a lock.
    """

    def __init__(self, *, workers: int = RENDER_WORKERS, kept: int = ANSWERS_KEPT) -> None:
        if workers < 1 or kept < 1:
            raise ValueError(f"workers and kept must be >= 1, not {workers} and {kept}")
        self._pool = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="render")
        self._kept = kept
        self._lock = threading.RLock()  # a computation done at once calls back in get
        self._done: OrderedDict[Hashable, Any] = OrderedDict()
        self._running: dict[Hashable, Future[Any]] = {}
        #: How many answers were computed (not taken from the cache).
        self.computed = 0

    async def get(self, key: Hashable, compute: Callable[[], Any]) -> Any:
        """The answer of ``key``: kept, being computed (waited for), or ``compute()`` run
        in the pool now. An exception is raised to every request waiting and nothing kept."""
        with self._lock:
            if key in self._done:
                self._done.move_to_end(key)
                return self._done[key]
            running = self._running.get(key)
            if running is None:
                running = self._pool.submit(compute)
                self._running[key] = running
                self.computed += 1
                running.add_done_callback(lambda done: self._finished(key, done))
        # shielded: a request that goes away does not cancel the others' computation
        return await asyncio.shield(asyncio.wrap_future(running))

    def _finished(self, key: Hashable, done: Future[Any]) -> None:
        with self._lock:
            self._running.pop(key, None)
            if done.cancelled() or done.exception() is not None:
                return
            self._done[key] = done.result()
            while len(self._done) > self._kept:
                self._done.popitem(last=False)

    def close(self) -> None:
        """Stop the pool (what is running finishes)."""
        self._pool.shutdown(wait=False, cancel_futures=True)
