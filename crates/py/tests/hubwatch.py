"""A real `colony hub` and a subscriber of colony's own Python client, for the
tests of the "human" view: what an environment publishes, a subscriber hears."""

import os
import select
import sys
import time

# The protocol client and its test harness's hub, from the repository's python/.
ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..")
sys.path[:0] = [os.path.join(ROOT, "python"), os.path.join(ROOT, "python", "tests")]
import colony_client  # noqa: E402
from test_client import Hub  # noqa: E402


def heard(test, subject, make_env, step, seconds=20.0):
    """Starts a hub and a subscriber of `subject`, makes the environment with
    `make_env(hub_address)` and steps it with `step(env)` until the subscriber has
    heard a packet (or the episode or the time ends); returns what it heard."""
    hub = Hub()
    test.addCleanup(hub.log.close)
    hub.start()
    test.addCleanup(hub.stop)
    watcher = colony_client.Client(hub.addr)
    test.addCleanup(watcher.close)
    watcher.subscribe(subject)
    env = make_env(hub.addr_text)
    test.addCleanup(env.close)
    got = []

    def listen(wait):
        # The subscriber owns its loop: it answers the hub's cookie and reads.
        select.select([watcher], [], [], wait)
        watcher.poll()
        while (p := watcher.recv()) is not None:
            got.append(p)

    deadline = time.monotonic() + seconds
    while env.agents and not got and time.monotonic() < deadline:
        step(env)
        listen(0.0)
    while not got and time.monotonic() < deadline:
        listen(0.2)
    return got
