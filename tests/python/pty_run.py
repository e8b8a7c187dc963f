"""A command run with a pseudo-terminal as its stdout and stderr, as a user
at a terminal runs it (the batches' progress bars): used by
tests/python/test_batch.py (the CLI) and tests/blender/test_addon.py
(bake_world.py in headless Blender)."""
import os
import pty
import select
import time


def run_on_a_terminal(argv, env=None, timeout=120):
    """(exit code, everything it printed) of argv[0] run with argv; env: its
    environment (default: this process's)."""
    pid, fd = pty.fork()
    if pid == 0:
        if env is None:
            os.execv(argv[0], argv)
        os.execve(argv[0], argv, env)
    out, end = b"", time.monotonic() + timeout
    while time.monotonic() < end:
        if select.select([fd], [], [], 0.5)[0]:
            try:
                chunk = os.read(fd, 65536)
            except OSError:
                break
            if not chunk:
                break
            out += chunk
    _, status = os.waitpid(pid, 0)
    os.close(fd)
    return os.waitstatus_to_exitcode(status), out.decode("utf-8", "replace")
