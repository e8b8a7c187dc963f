"""A bake on a background thread, for the modal operator: the native code
releases the GIL, so Blender's UI keeps running; cancel() makes the next
progress callback return False, and the bake then stops without writing."""
import threading
from typing import Callable, Optional

from . import native


class BakeJob:
    def __init__(self, work: Callable[[Callable[[str, float], bool]], object]):
        """`work(progress)` runs on the thread; its result or exception is kept."""
        self._work = work
        self._lock = threading.Lock()
        self._cancel = threading.Event()
        self.stage, self.fraction = "starting", 0.0
        self.result: Optional[object] = None
        self.error: Optional[BaseException] = None
        self.cancelled = False
        self._thread = threading.Thread(target=self._run, name="iblbake", daemon=True)

    def start(self):
        self._thread.start()
        return self

    def _progress(self, stage: str, fraction: float) -> bool:
        with self._lock:
            self.stage, self.fraction = stage, fraction
        return not self._cancel.is_set()

    def _run(self):
        try:
            self.result = self._work(self._progress)
        except native.load().Cancelled:
            self.cancelled = True
        except BaseException as e:  # reported by the operator on the main thread
            self.error = e

    def cancel(self):
        self._cancel.set()

    def done(self) -> bool:
        return not self._thread.is_alive()

    def wait(self, timeout: Optional[float] = None) -> bool:
        self._thread.join(timeout)
        return self.done()

    def status(self):
        with self._lock:
            return self.stage, self.fraction
