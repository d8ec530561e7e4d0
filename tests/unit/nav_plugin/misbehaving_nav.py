"""A navigator process that misbehaves on purpose (standard library only).

Usage: python misbehaving_nav.py MODE. It answers hello and reset properly (unless the mode
says otherwise), then on the first step:
  crash           writes two stderr lines and exits with code 3
  segv            kills itself with SIGSEGV
  hang            sleeps (never answers)
  hang-child      starts a grandchild ``sleep`` in its process group, then sleeps
  garbage         prints a line that is not JSON
  nan             answers a command with v = NaN
  wrong-type      answers {"type": "ok"} to a step
  slow            answers correctly after 0.3 s
Modes acting before the first step: garbage-hello (prints text instead of hello),
old-protocol (hello with protocol 99), refuse-reset (status error to reset).
"""

import json
import os
import signal
import subprocess
import sys
import time

mode = sys.argv[1]


def send(obj):
    sys.stdout.write((obj if isinstance(obj, str) else json.dumps(obj)) + "\n")
    sys.stdout.flush()


for line in sys.stdin:
    msg = json.loads(line)
    kind = msg["type"]
    if kind == "hello":
        if mode == "garbage-hello":
            send("Hello world! I am a navigator.")
        elif mode == "old-protocol":
            send({"type": "hello", "protocol": 99})
        else:
            send({"type": "hello", "protocol": 1, "name": "misbehaving-" + mode})
    elif kind == "reset":
        if mode == "refuse-reset":
            send({"type": "status", "kind": "error", "message": "mission too long"})
        else:
            send({"type": "ok"})
    elif kind == "step":
        if mode == "crash":
            sys.stderr.write("planner: loading map\nfatal: simulated crash in planner\n")
            sys.stderr.flush()
            sys.exit(3)
        if mode == "segv":
            os.kill(os.getpid(), signal.SIGSEGV)
        if mode == "hang":
            time.sleep(120)
        if mode == "hang-child":
            subprocess.Popen(["sleep", "120"])
            time.sleep(120)
        if mode == "garbage":
            send("[planner] arcs evaluated: 20")
            continue
        if mode == "nan":
            send('{"type": "command", "v": NaN, "omega": 0.0}')
            continue
        if mode == "wrong-type":
            send({"type": "ok"})
            continue
        if mode == "slow":
            time.sleep(0.3)
        send({"type": "command", "v": 0.5, "omega": 0.0})
    elif kind == "close":
        break
