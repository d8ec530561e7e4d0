"""A navigator process (standard library only) that gives up at its first step with the mission
it was sent as its message (to see what crossed the line protocol).

Usage: python mission_nav.py
"""

import json
import sys

mission = None
for line in sys.stdin:
    msg = json.loads(line)
    if msg["type"] == "hello":
        print(json.dumps({"type": "hello", "protocol": 1, "name": "mission"}), flush=True)
    elif msg["type"] == "reset":
        mission = msg["mission"]
        print(json.dumps({"type": "ok"}), flush=True)
    elif msg["type"] == "step":
        print(json.dumps({"type": "status", "kind": "error", "message": json.dumps(mission)}), flush=True)
    elif msg["type"] == "close":
        break
