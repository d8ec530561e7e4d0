"""A navigator process (standard library only) that drives straight and, with ``chatty``, writes
200 KB of log lines on stderr at every step.

Usage: python chatty_nav.py quiet|chatty
"""

import json
import sys

chatty = sys.argv[1] == "chatty"
LOG = ("planner: evaluating arcs " + "x" * 75 + "\n") * 2000  # 200 KB

for line in sys.stdin:
    kind = json.loads(line)["type"]
    if kind == "hello":
        print(json.dumps({"type": "hello", "protocol": 1, "name": "chatty"}), flush=True)
    elif kind == "reset":
        print(json.dumps({"type": "ok"}), flush=True)
    elif kind == "step":
        if chatty:
            sys.stderr.write(LOG)
            sys.stderr.flush()
        print(json.dumps({"type": "command", "v": 0.5, "omega": 0.0}), flush=True)
    elif kind == "close":
        break
