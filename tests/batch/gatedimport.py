"""A module whose import waits until the file named by $LEGPLAN_TEST_GATE exists (at most a minute):
it stands for the slow imports of a fork server's preload list in the `prestart` test."""

import os
import time

_deadline = time.monotonic() + 60.0
while not os.path.exists(os.environ["LEGPLAN_TEST_GATE"]) and time.monotonic() < _deadline:
    time.sleep(0.01)
