"""A navigator process (standard library only) that answers every step with the same reply line.

Usage: python echo_nav.py REPLY_JSON
"""

import json
import sys

reply = sys.argv[1]

for line in sys.stdin:
    kind = json.loads(line)["type"]
    if kind == "hello":
        print(json.dumps({"type": "hello", "protocol": 1, "name": "echo"}), flush=True)
    elif kind == "reset":
        print(json.dumps({"type": "ok"}), flush=True)
    elif kind == "step":
        print(reply, flush=True)
    elif kind == "close":
        break
